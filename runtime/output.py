"""Writing output files: every writer of depsim (CSV, JSON, plots, animations, NetCDF studies)
goes through `atomic_path`, so a failure never leaves a half-written file and a path is never
turned into something else than it was.

What a path names decides how it is written:

* a regular file, or nothing yet: a temporary file in the same folder, then a rename over it
  (atomic). A symbolic link is followed: its target is replaced, the link stays. An existing
  file keeps its permission bits; a read-only one is refused.
* a pipe (FIFO), a character device (/dev/null, a terminal) or one of this process's open
  descriptors (/dev/stdout, /dev/fd/N): written in place, never replaced; a descriptor is
  written through itself, after what the process printed there. (The content is first
  written to a temporary file in the system's temporary folder, then copied in.)
* a folder, a block device, a socket: refused.

`check_output` says beforehand whether a path can be written (the CLI checks every output
before it runs anything), and `all_or_none` writes several files as one: all of them or none.
Errors are `OutputError`, an `OSError` whose message names the path as the user gave it.
"""

from __future__ import annotations

import contextlib
import contextvars
import os
import shutil
import stat
import sys
import tempfile
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass, field
from pathlib import Path

__all__ = ["OutputError", "atomic_path", "all_or_none", "when_written", "check_output",
           "check_format", "writes_in_place"]


class OutputError(OSError):
    """An output file cannot be written as asked: its folder is missing or not writable, the
    path is a folder or a read-only file, or its extension names a format the writer lacks."""


def check_format(path: str | os.PathLike, formats: Sequence[str]) -> None:
    """OutputError unless the extension of `path` is one of `formats` (lower case, no dot)."""
    path = Path(path)
    suffix = path.suffix.lower().lstrip(".")
    if suffix not in formats:
        found = f"unknown format '.{suffix}'" if suffix else "no extension"
        raise OutputError(f"cannot write {path}: {found}; "
                          f"use one of {', '.join('.' + f for f in formats)}")


def writes_in_place(path: str | os.PathLike) -> bool:
    """Whether `path` is written in place (a pipe, a device, a descriptor), not replaced."""
    return _target(Path(path))[1]


def check_output(path: str | os.PathLike, formats: Sequence[str] = ()) -> None:
    """OutputError unless `path` can be written (module docstring): its folder exists and a
    file can be created there (tried, then removed), or it is a pipe or device open to
    writing. `formats`: the extensions accepted (lower case, no dot); empty: any."""
    path = Path(path)
    if formats:
        check_format(path, formats)
    target, in_place, _ = _target(path)
    if in_place:
        if not os.access(target, os.W_OK):
            raise OutputError(f"cannot write {path}: permission denied")
        return
    folder = _folder(path, target)
    if not target.parent.is_dir():
        raise OutputError(f"cannot write {path}: folder '{folder}' does not exist")
    try:
        fd, probe = tempfile.mkstemp(dir=target.parent, prefix=f".{target.name}.",
                                     suffix=".probe")
    except OSError as exc:
        raise OutputError(f"cannot write {path}: no file can be created in folder '{folder}' "
                          f"({exc.strerror or exc})") from None
    os.close(fd)
    os.unlink(probe)


@contextlib.contextmanager
def atomic_path(path: str | os.PathLike) -> Iterator[str]:
    """Yield a temporary path to write `path` through. On success the content is put in place
    (module docstring), at once or at the end of an enclosing `all_or_none` block; on failure
    the temporary file is removed and `path` is left alone. The temporary name ends with the
    extension of `path`, so writers that choose a format by extension see the right one."""
    path = Path(path)
    target, in_place, descriptor = _target(path)
    try:
        fd, tmp = tempfile.mkstemp(dir=None if in_place else target.parent,
                                   prefix=f".{target.name}.", suffix=f".tmp{target.suffix}")
    except OSError as exc:
        if not in_place and not target.parent.is_dir():
            raise OutputError(f"cannot write {path}: folder '{_folder(path, target)}' does "
                              "not exist") from None
        raise OutputError(f"cannot write {path}: {exc.strerror or exc}") from None
    os.close(fd)
    try:
        yield tmp
    except BaseException:
        _remove(tmp)
        raise
    write = _Write(path, tmp, target, in_place, descriptor)
    batch = _BATCH.get()
    if batch is None:
        write.put_in_place()
    else:
        batch.writes.append(write)


@contextlib.contextmanager
def all_or_none() -> Iterator[None]:
    """Write several files as one. Inside the block every `atomic_path` keeps its content in
    its temporary file; when the block ends they are put in place in order. If the block
    raises, or a file cannot be put in place, no file is: those already put in place by this
    block are removed again (a pipe or device cannot take back what it was sent) and every
    temporary file is deleted. Callbacks given to `when_written` run after all are in place.
    A block inside another joins the outer one."""
    if _BATCH.get() is not None:
        yield
        return
    batch = _Batch()
    token = _BATCH.set(batch)
    try:
        yield
    except BaseException:
        for write in batch.writes:
            _remove(write.tmp)
        raise
    finally:
        _BATCH.reset(token)
    done: list[_Write] = []
    try:
        for write in batch.writes:
            write.put_in_place()
            done.append(write)
    except BaseException:
        for write in batch.writes:
            _remove(write.tmp)
        for write in done:
            if not write.in_place:
                _remove(write.target)
        raise
    for callback in batch.after:
        callback()


def when_written(callback: Callable[[], None]) -> None:
    """Call `callback` once the files being written are in place: at the end of the enclosing
    `all_or_none` block (never, if it fails), or now outside one."""
    batch = _BATCH.get()
    if batch is None:
        callback()
    else:
        batch.after.append(callback)


@dataclass
class _Write:
    path: Path  # as the user gave it, for messages
    tmp: str
    target: Path
    in_place: bool
    descriptor: int | None  # this process's descriptor that `path` names, if it names one

    def put_in_place(self) -> None:
        try:
            if self.in_place:
                with open(self.tmp, "rb") as source, self._open_in_place() as sink:
                    shutil.copyfileobj(source, sink)
            else:
                os.chmod(self.tmp, _mode(self.target))
                os.replace(self.tmp, self.target)
        except OSError as exc:
            raise OutputError(f"cannot write {self.path}: {exc.strerror or exc}") from exc
        finally:
            _remove(self.tmp)

    def _open_in_place(self):
        if self.descriptor is None:
            return open(self.target, "wb")
        for stream in (sys.stdout, sys.stderr):  # what was printed there goes first
            with contextlib.suppress(AttributeError, OSError, ValueError):
                if stream.fileno() == self.descriptor:
                    stream.flush()
        return open(os.dup(self.descriptor), "wb")  # shares the offset with the original


@dataclass
class _Batch:
    writes: list[_Write] = field(default_factory=list)
    after: list[Callable[[], None]] = field(default_factory=list)


_BATCH: contextvars.ContextVar[_Batch | None] = contextvars.ContextVar("depsim_output_batch",
                                                                       default=None)


def _target(path: Path) -> tuple[Path, bool, int | None]:
    """(the file to write, whether it is written in place, the descriptor of this process
    that `path` names or None): see the module docstring."""
    try:
        status = os.stat(path)
    except FileNotFoundError:
        status = None  # nothing yet, or a link to nothing yet: created
    except OSError as exc:  # a file used as a folder, a loop of links, ...
        raise OutputError(f"cannot write {path}: {exc.strerror or exc}") from None
    if status is None:
        return Path(os.path.realpath(path)), False, None
    mode = status.st_mode
    if stat.S_ISDIR(mode):
        raise OutputError(f"cannot write {path}: it is a folder; give a file name")
    if not (stat.S_ISREG(mode) or stat.S_ISFIFO(mode) or stat.S_ISCHR(mode)):
        raise OutputError(f"cannot write {path}: it is neither a file, a pipe nor a "
                          "character device")
    through_proc, descriptor = _through_proc(path)
    if through_proc or not stat.S_ISREG(mode):
        return path, True, descriptor
    if not os.access(path, os.W_OK):
        raise OutputError(f"cannot write {path}: the file is read-only")
    return Path(os.path.realpath(path)), False, None


def _through_proc(path: Path) -> tuple[bool, int | None]:
    """(whether `path` leads through /proc, the descriptor number when it names one of this
    process's: /dev/stdout, /dev/fd/N, /proc/self/fd/N). Such a path is an open file
    descriptor: written in place, not replaced."""
    own = (f"/proc/{os.getpid()}/fd", "/proc/self/fd")
    current = os.path.abspath(path)
    for _ in range(40):  # the kernel's own limit on links followed
        folder = os.path.realpath(os.path.dirname(current))
        name = os.path.basename(current)
        if folder in own and name.isdigit():
            return True, int(name)
        if folder == "/proc" or folder.startswith("/proc/"):
            return True, None
        current = os.path.join(folder, name)
        if not os.path.islink(current):
            return False, None
        current = os.path.join(folder, os.readlink(current))
    return False, None


def _folder(path: Path, target: Path) -> str:
    """The folder to name in a message: as the user wrote it, unless a link leads elsewhere."""
    if os.path.islink(path):
        return str(target.parent)
    return str(path.parent)


def _mode(target: Path) -> int:
    """An existing file's permission bits; else 0666 less the umask, as open() would give."""
    try:
        return stat.S_IMODE(os.stat(target).st_mode)
    except FileNotFoundError:
        umask = os.umask(0)
        os.umask(umask)
        return 0o666 & ~umask


def _remove(path) -> None:
    with contextlib.suppress(FileNotFoundError):
        os.unlink(path)
