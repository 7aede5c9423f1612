"""Text -> syntax tree, reporting every syntax error it can find in one pass.

lark's LALR parser runs with an `on_error` handler. On an error the handler records a
diagnostic (worded by `syntax_messages`), then recovers in panic mode: it pops the parser
stack back to the last statement or block-item boundary and moves the lexer to the end of
the offending item (skipping any block it opens), so parsing resumes at the next item and
later errors are reported too.
"""

from __future__ import annotations

import functools
import unicodedata
from pathlib import Path

from lark import Lark, Token, Tree, UnexpectedInput, UnexpectedToken
from lark.exceptions import VisitError
from lark.lexer import LineCounter

from .errors import Reporter
from .ir import Span
from .syntax import AstExpr, SourceFile, ToSyntax
from .syntax_messages import describe_syntax_error, keyword_replay

MAX_SYNTAX_ERRORS = 20
MAX_NESTING = 64  # parentheses deeper than this are refused before parsing
MAX_EXPRESSION_DEPTH = 100  # operators, signs, units and calls inside one another
MAX_NAME_LENGTH = 64  # characters of a name
MAX_NON_ASCII_ERRORS = 10

# The expression nodes of lark's tree (grammar.lark's aliases): each is one level of depth.
_EXPRESSION_NODES = frozenset({"add", "sub", "mul", "div", "neg", "pos", "pow", "with_unit",
                               "call", "ref", "number", "pick"})
# Characters people paste for ASCII ones that NFKC normalisation does not map.
_LOOKALIKES = {"\u2212": "-", "\u2013": "-", "\u2014": "-", "\u00d7": "*", "\u00b7": "*",
               "\u22c5": "*", "\u2217": "*", "\u201c": '"', "\u201d": '"', "\u00a0": " "}


@functools.cache
def parser() -> Lark:
    """The .dep parser (built once per process)."""
    grammar = Path(__file__).with_name("grammar.lark").read_text(encoding="utf-8")
    return Lark(grammar, parser="lalr", lexer="contextual", propagate_positions=True,
                maybe_placeholders=False, start=["start", "expr"])


@functools.cache
def boundary_states() -> frozenset[int]:
    """Parser states where a new statement or block item may start: those that can shift
    a statement keyword (top level) or 'point' (inside a block)."""
    table = parser().parser.parser.parser.parse_table
    return frozenset(state for state, actions in table.states.items()
                     if "MODEL" in actions or "POINT" in actions)


def parse_source(text: str, filename: str, report: Reporter) -> SourceFile | None:
    """Parse `text`; None when it has syntax errors (all recorded in `report`)."""
    if not _ascii_ok(text, filename, report) or not _nesting_ok(text, filename, report):
        return None
    source = text if text.endswith("\n") else text + "\n"
    recovery = _Recovery(source, filename, report)
    tree = None
    try:
        tree = parser().parse(source, start="start", on_error=recovery.on_error)
    except UnexpectedInput as error:  # recovery gave up; the error may be new
        recovery.record(error)
    if recovery.count or tree is None:
        return None
    return _to_syntax(tree, filename, report)


def parse_expression(text: str, filename: str, report: Reporter) -> AstExpr | None:
    """Parse one expression (e.g. a value given on the command line); None on errors."""
    if not _ascii_ok(text, filename, report) or not _nesting_ok(text, filename, report):
        return None
    try:
        tree = parser().parse(text, start="expr")
    except UnexpectedInput as error:
        code, message, hint, span = describe_syntax_error(error, text, filename)
        report.error(code, message, span, hint)
        return None
    return _to_syntax(tree, filename, report)


def _to_syntax(tree, filename: str, report: Reporter):
    if not _tree_ok(tree, filename, report):
        return None
    try:
        return ToSyntax(filename).transform(tree)
    except VisitError as error:
        if not isinstance(error.orig_exc, RecursionError):
            raise
    except RecursionError:
        pass
    report.error("E006", "the text is nested too deeply to read", Span(filename, 1, 1, 1, 2))
    return None


def _tree_ok(tree: Tree, filename: str, report: Reporter) -> bool:
    """Report names longer than MAX_NAME_LENGTH and expressions deeper than
    MAX_EXPRESSION_DEPTH (E006: every later stage walks them recursively). Iterative."""
    ok = True
    too_deep: set[int] = set()  # ids of the outermost expressions reported (once each)
    stack: list[tuple[Tree | Token, int, Tree]] = [(tree, 0, tree)]
    while stack:
        node, depth, outermost = stack.pop()
        if isinstance(node, Token):
            if node.type == "NAME" and len(node) > MAX_NAME_LENGTH:
                ok = False
                report.error("E008", f"the name '{node[:24]}...' is {len(node)} characters "
                             f"long; names have at most {MAX_NAME_LENGTH}",
                             Span(filename, node.line, node.column, node.end_line,
                                  node.end_column))
            continue
        if node.data in _EXPRESSION_NODES:
            depth += 1
            outermost = outermost if depth > 1 else node
            if depth > MAX_EXPRESSION_DEPTH:
                ok = False
                if id(outermost) in too_deep:
                    continue
                too_deep.add(id(outermost))
                meta = outermost.meta
                report.error("E006", f"expression nested more than {MAX_EXPRESSION_DEPTH} "
                             "levels deep (operators, signs and calls inside one another)",
                             Span(filename, meta.line, meta.column, meta.end_line,
                                  meta.end_column),
                             hint="split it with param statements")
                continue
        stack.extend((child, depth, outermost) for child in node.children)
    return ok


def _ascii_ok(text: str, filename: str, report: Reporter) -> bool:
    """Report every non-ASCII character outside comments and descriptions (a full-width
    digit would otherwise read as a digit, a lookalike minus as an unknown character)."""
    if text.isascii():
        return True
    found = 0
    for number, line in enumerate(text.split("\n"), start=1):
        in_string = False
        for col, char in enumerate(line, start=1):
            if char == '"':
                in_string = not in_string
            elif char == "#" and not in_string:
                break
            elif not char.isascii() and not in_string:
                found += 1
                message, hint = _non_ascii(char)
                report.error("E001", message, Span(filename, number, col, number, col + 1),
                             hint)
                if found >= MAX_NON_ASCII_ERRORS:
                    return False
    return not found


def _non_ascii(char: str) -> tuple[str, str]:
    """The message and hint for a non-ASCII character in model text."""
    name = unicodedata.name(char, f"U+{ord(char):04X}")
    shown = char if char.isprintable() and not char.isspace() else f"U+{ord(char):04X}"
    message = f"non-ASCII character '{shown}' ({name})"
    plain = unicodedata.normalize("NFKC", char)
    if not plain.isascii() or not plain.isprintable():
        plain = _LOOKALIKES.get(char, "")
    if "SUPERSCRIPT" in name and plain.isdigit():  # m² for m^2
        return f"{message}: a power is written with '^'", f"write ^{plain}"
    if char.isdigit() or plain.isdigit():
        digit = plain if plain.isdigit() else str(unicodedata.digit(char, ""))
        return f"{message}: numbers are written with the ASCII digits 0-9", \
            f"write {digit}" if digit else ""
    if char.isalpha():
        return f"{message}: names are written with ASCII letters, digits and '_'", \
            f"write {plain}" if plain.isalpha() else ""
    return f"{message}: model text is ASCII outside comments and descriptions", \
        f"write '{plain}'" if plain else ""


def _nesting_ok(text: str, filename: str, report: Reporter) -> bool:
    depth = 0
    line, col = 1, 0
    for ch in text:
        col += 1
        if ch == "\n":
            line, col, depth = line + 1, 0, 0
        elif ch == "(":
            depth += 1
            if depth > MAX_NESTING:
                report.error("E006", f"parentheses nested more than {MAX_NESTING} deep",
                             Span(filename, line, col, line, col + 1))
                return False
        elif ch == ")":
            depth -= 1
    return True


class _Recovery:
    """The on_error handler: record, then resynchronise at the next item."""

    def __init__(self, text: str, filename: str, report: Reporter) -> None:
        self.text = text
        self.filename = filename
        self.report = report
        self.count = 0
        self.seen: set[tuple[int, int]] = set()

    def record(self, error: UnexpectedInput) -> bool:
        """Report `error` unless already reported; False when the limit is reached."""
        where = (error.line, error.column)
        if where in self.seen or self.count >= MAX_SYNTAX_ERRORS:
            return False
        self.seen.add(where)
        self.count += 1
        code, message, hint, span = describe_syntax_error(error, self.text, self.filename)
        self.report.error(code, message, span, hint)
        return True

    def on_error(self, error: UnexpectedInput) -> bool:
        if not self.record(error):
            return False
        if isinstance(error, UnexpectedToken) and error.token.type == "$END":
            return False
        ip = error.interactive_parser
        if isinstance(error, UnexpectedToken) and self._close_block(error):
            return True
        _pop_to_boundary(ip.parser_state)
        start = error.token.start_pos if isinstance(error, UnexpectedToken) \
            else error.pos_in_stream
        in_block = "RBRACE" in parser().parser.parser.parser.parse_table.states[
            ip.parser_state.position]
        self._move_lexer(ip, _skip_item(self.text, start, in_block))
        return True

    def _close_block(self, error: UnexpectedToken) -> bool:
        """A statement keyword inside a block: assume the block's '}' is missing, close it
        and carry on with the statement."""
        replay = keyword_replay(error)
        if not replay:
            return False
        trial = error.interactive_parser.copy()
        try:
            _pop_to_boundary(trial.parser_state)
            for token_type, value in (("RBRACE", "}"), ("_NL", "\n")):
                trial.feed_token(Token.new_borrow_pos(token_type, value, replay[0]))
            for token in replay:
                trial.feed_token(token)
        except UnexpectedToken:
            return False
        ip = error.interactive_parser
        ip.parser_state.state_stack[:] = trial.parser_state.state_stack
        ip.parser_state.value_stack[:] = trial.parser_state.value_stack
        return True

    def _move_lexer(self, ip, position: int) -> None:
        counter = LineCounter("\n")
        counter.feed(self.text[:position])
        ip.lexer_thread.state.line_ctr = counter


def _pop_to_boundary(state) -> None:
    boundary = boundary_states()
    while state.state_stack[-1] not in boundary and len(state.state_stack) > 1:
        state.state_stack.pop()
        state.value_stack.pop()


def _skip_item(text: str, start: int, in_block: bool) -> int:
    """Where to resume after a bad item starting near `start`: before the next separator
    ('\\n' or ';') outside any braces opened on the way, or before the '}' closing the
    enclosing block."""
    depth, i = 0, start
    while i < len(text):
        ch = text[i]
        if ch == "#":  # a comment runs to the end of the line
            end = text.find("\n", i)
            i = len(text) if end == -1 else end
            continue
        if ch == '"':
            end = text.find('"', i + 1)
            newline = text.find("\n", i + 1)
            i = end + 1 if end != -1 and (newline == -1 or end < newline) else i + 1
            continue
        if ch in "\n;" and depth == 0:
            return i
        if ch == "{":
            depth += 1
        elif ch == "}":
            if depth == 0 and in_block:
                return i
            depth = max(depth - 1, 0)
        i += 1
    return len(text)
