"""dep_format_double (runtime/c/decimal.c): a double as printf's "%.17g" writes it, without the
C library's multiple-precision arithmetic. Checked against snprintf itself on a million
doubles, and its table of powers of ten against Python's exact integers.

Regenerate the table with:  python tests/c/test_decimal.py > runtime/c/base/decimal_powers.inc
"""
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
HERE = Path(__file__).resolve().parent
SOURCES = ROOT / "runtime" / "c"
TABLE = SOURCES / "base" / "decimal_powers.inc"
LOWEST, HIGHEST = -292, 340  # 16 - k for the largest double (k = 308) and the smallest (-324)


def power(p: int) -> tuple[int, int]:
    """10^p as T 2^b, T the 128-bit integer with its top bit set, truncated (exact integers)."""
    if p >= 0:
        value = 10 ** p
        b = value.bit_length() - 128
        return (value >> b if b >= 0 else value << -b), b
    divisor = 10 ** -p
    s = 127 + divisor.bit_length()
    while (1 << s) // divisor >= 1 << 128:
        s -= 1
    while (1 << s) // divisor < 1 << 127:
        s += 1
    return (1 << s) // divisor, -s


def header_text() -> str:
    lines = ["/* decimal_powers.inc: 10^p = (high 2^64 + low) 2^exponent for p = DEP_POWERS_LOWEST ..",
             " * DEP_POWERS_HIGHEST, high's top bit set, truncated from the exact value. Made and",
             " * checked by tests/c/test_decimal.py. */",
             "#define DEP_POWERS_LOWEST (%d)" % LOWEST,
             "#define DEP_POWERS_HIGHEST %d" % HIGHEST,
             "static const dep_power dep_powers[] = {"]
    for p in range(LOWEST, HIGHEST + 1):
        t, b = power(p)
        lines.append("    {0x%016xULL, 0x%016xULL, %d}, /* 10^%d */" % (t >> 64, t & (2**64 - 1), b, p))
    lines.append("};")
    return "\n".join(lines) + "\n"


def test_the_table_is_the_exact_powers_of_ten_truncated():
    assert TABLE.read_text(encoding="utf-8") == header_text()


def test_writes_every_double_as_snprintf_does(tmp_path):
    """Four kinds of doubles, a million of each (tests/c/decimal_check.c): every bit pattern,
    decimals of up to 8 digits (near ties and powers of ten), exact binary ties at the 17th
    digit, and each power of ten with its neighbours and the specials: the same characters
    as snprintf's "%.17g", which reads back exactly."""
    from depsim.runtime.core import compiler

    program = tmp_path / "decimal_check"
    subprocess.run([*compiler(), "-O2", "-std=c99", "-Wall", "-Wextra", "-Wpedantic", "-Werror",
                    f"-I{SOURCES / 'include'}", "-o", str(program), str(HERE / "decimal_check.c"),
                    str(SOURCES / "base" / "decimal.c"), "-lm"], check=True)
    done = subprocess.run([str(program), "1000000", "20261124"], capture_output=True, text=True,
                          check=True)
    last = done.stdout.splitlines()[-1].split()
    assert last[0] == "checked" and int(last[1]) > 4_000_000 and last[2:] == ["differ", "0"], \
        done.stdout


if __name__ == "__main__":
    sys.stdout.write(header_text())
