"""Syntax errors in words: what was expected, what was found, and a hint.

Common mistakes are recognised with lark's `match_examples` (each label below lists broken
snippets that fail in the same parser state); everything else is described from the set
of terminals the parser would have accepted.
"""

from __future__ import annotations

from lark import Token, UnexpectedCharacters, UnexpectedInput, UnexpectedToken
from lark.lexer import PatternStr

from .errors import did_you_mean
from .ir import Span
from .syntax import KEYWORDS, STATEMENT_WORDS
from .units import unit_suggestion

STATEMENT_KEYWORDS = frozenset(word.upper() for word in STATEMENT_WORDS)  # terminal names
KEYWORD_TERMINALS = {word.upper(): word for word in KEYWORDS}  # terminal name -> keyword

# label -> broken snippets that fail in the state the label describes.
EXAMPLES: dict[str, list[str]] = {
    "expected '=' after the attribute name": [
        "bar b {\n mass 2 kg\n}\n", "initial {\n h1.rate 0\n}\n"],
    "expected '=' after the parameter name": ["param k 2\n"],
    "expected '=' after the output name": ["output o h1\n"],
    "expected '=' after 'gravity'": ["gravity (0, 1)\n"],
    "expected a value after '='": [
        "param k =\n", "output o =\n", "bar b {\n mass =\n}\n"],
    "expected a value after the operator": [
        "param k = 1 +\n", "param k = 1 -\n", "param k = 1 *\n", "param k = 1 /\n",
        "param k = 1 ^\n", "param k = -\n", "param k = +\n", "param k = 1 ^ -\n"],
    "expected a vector (x, y) after '='": [
        "gravity = 9.81\n", "ground {\n point p = 1\n}\n"],
    "expected 'joins' after the joint name": ["hinge h ground.origin to a.b\n"],
    "expected 'to' between the two attachment points": ["hinge h joins a.b c.d\n"],
    "expected an attachment point MEMBER.POINT, e.g. yoke.a": [
        "hinge h joins a to b.c\n", "hinge h joins a.b to c\n",
        "hinge h joins 1\n", "hinge h joins a.b to 1\n"],
    "expected '{' to open the block": [
        "bar b\n", "ground\n", "cable c\n", "initial\n", "simulate\n", "bar b =\n"],
    "expected the model name after 'model'": ["model\n", "model 1\n"],
}

_ORDER = ["a statement", "an attribute", "a value", "an operator", "a unit", "a name",
          "a number", "a quoted description"]


def describe_syntax_error(error: UnexpectedInput, text: str, filename: str
                          ) -> tuple[str, str, str, Span]:
    """(code, message, hint, span) for a lark error."""
    if isinstance(error, UnexpectedCharacters):
        return _bad_character(error, text, filename)
    assert isinstance(error, UnexpectedToken)
    token = error.token
    expected = set(error.accepts or error.expected)
    if expected - {"LSQB"}:  # an index may follow most names: not worth saying
        expected.discard("LSQB")
    span = _token_span(token, filename)
    replay = keyword_replay(error)
    if token.type == "$END" or replay:
        opened = _open_brace(error)
        if opened is not None and (replay or "RBRACE" in expected):
            where = "end of file" if token.type == "$END" else f"'{replay[0]}'"
            return ("E001", f"missing '}}': the block opened here is not closed before {where}",
                    "", _token_span(opened, filename))
    if token.type == "RBRACE" and _open_brace(error) is None:
        return "E001", "unmatched '}': no block is open here", "", span
    glued = _glued_keyword(str(token), expected) if token.type == "NAME" else ""
    if token.type == "NAME":
        special = _unexpected_name(str(token), expected)
        if special:
            code, message, hint = special
            return code, message, glued or hint, span
    label = _match_example(error)
    found = _describe_token(token)
    if label:
        return "E001", f"{label}, found {found}", glued, span
    return "E001", f"expected {_words(expected)}{_after(error)}, found {found}", glued, span


def _glued_keyword(name: str, expected: set[str]) -> str:
    """A hint when `name` is an expected keyword run together with what follows it
    (`paramL`, `joinsground`): a keyword ends at a space."""
    words = [KEYWORD_TERMINALS[t] for t in expected if t in KEYWORD_TERMINALS]
    glued = [w for w in words if name.startswith(w) and len(name) > len(w)]
    if not glued:
        return ""
    word = max(glued, key=len)
    return f"a keyword ends at a space: write '{word} {name[len(word):]}'"


def _bad_character(error: UnexpectedCharacters, text: str, filename: str
                   ) -> tuple[str, str, str, Span]:
    span = Span(filename, error.line, error.column, error.line, error.column + 1)
    char = text[error.pos_in_stream] if error.pos_in_stream < len(text) else ""
    if char == '"':
        return ("E001", "unterminated string: a description ends with '\"' on the same line",
                "", span)
    shown = repr(char)[1:-1] if not char.isprintable() else char
    expected = _words({t for t in error.allowed or () if not t.startswith("__")})
    return "E001", f"unexpected character '{shown}'; expected {expected}", "", span


def _unexpected_name(name: str, expected: set[str]) -> tuple[str, str, str] | None:
    """Messages for a name where a statement or a unit was expected."""
    if expected & STATEMENT_KEYWORDS and "NAME" not in expected:
        hint = did_you_mean(name, STATEMENT_WORDS) or \
            "attributes go inside an element's block, e.g. bar yoke { mass = 2 kg }"
        return "E001", f"unknown statement '{name}'", hint
    if "UNIT" in expected:
        meant = unit_suggestion(name) if name.isalpha() else ""
        if meant:
            return "E035", f"unknown unit '{name}'", f"did you mean '{meant}'?"
        return ("E001", f"expected an operator or a unit after the value, found name '{name}'",
                f"to multiply, write '*' before '{name}'")
    return None


class _SameState(int):
    """An LALR state number that compares equal to any parser state in that state. lark's
    own comparison also wants the same stack depth, which a snippet cannot reproduce for
    an error deep inside a file. (An int, because lark formats it with %d.)"""

    def __eq__(self, other: object) -> bool:
        return getattr(other, "position", other) == int(self)

    __hash__ = int.__hash__


def _match_example(error: UnexpectedInput) -> str | None:
    from .parse import parser  # the parser module imports this one

    state = error.state
    if state is None:
        return None
    error.state = _SameState(getattr(state, "position", state))
    try:
        return error.match_examples(lambda text: parser().parse(text, start="start"),
                                    EXAMPLES, use_accepts=True)
    finally:
        error.state = state


def keyword_replay(error: UnexpectedToken) -> list[Token]:
    """When a statement keyword turns up inside a block (its '}' is probably missing), the
    tokens to feed again after closing the block; [] otherwise. Inside a block the lexer
    reads a keyword as a NAME, so a NAME that starts an item and spells a keyword counts."""
    ip = getattr(error, "interactive_parser", None)
    if ip is None or _open_brace(error) is None:
        return []
    if error.token.type in STATEMENT_KEYWORDS:
        return [error.token]
    stack = ip.parser_state.value_stack
    if not stack or not isinstance(stack[-1], Token) or stack[-1].type != "NAME":
        return []
    from .parse import boundary_states

    starts_item = ip.parser_state.state_stack[-2] in boundary_states()
    if str(stack[-1]) not in STATEMENT_WORDS or not starts_item:
        return []
    keyword = Token.new_borrow_pos(str(stack[-1]).upper(), str(stack[-1]), stack[-1])
    return [keyword, error.token]


def _open_brace(error: UnexpectedToken) -> Token | None:
    """The '{' of the innermost block still open at the error."""
    ip = getattr(error, "interactive_parser", None)
    if ip is None:
        return None
    for value in reversed(ip.parser_state.value_stack):
        if isinstance(value, Token) and value.type == "LBRACE":
            return value
    return None


def _after(error: UnexpectedInput) -> str:
    """' after X' naming the last token the parser took, when there is one."""
    ip = getattr(error, "interactive_parser", None)
    stack = ip.parser_state.value_stack if ip is not None else []
    if stack and isinstance(stack[-1], Token) and stack[-1].type != "_NL":
        return f" after {_describe_token(stack[-1])}"
    return ""


def _describe_token(token: Token) -> str:
    kind = token.type
    if kind == "$END":
        return "end of file"
    if kind == "_NL":
        return "';'" if str(token).lstrip().startswith(";") else "end of line"
    if kind == "NAME":
        return f"name '{token}'"
    if kind == "NUMBER":
        return f"number {token}"
    if kind == "UNIT":
        return f"unit '{token}'"
    if kind == "STRING":
        return "a quoted string"
    if kind in STATEMENT_KEYWORDS or str(token).isalpha():
        return f"keyword '{token}'"
    return f"'{token}'"


def _words(expected: set[str]) -> str:
    """A set of terminals in words: "'=' or a name"."""
    words: set[str] = set()
    rest = set(expected)
    groups = [
        (STATEMENT_KEYWORDS, 5, "a statement"),
        (frozenset({"NAME", "POINT"}), 2, "an attribute"),
        (frozenset({"NAME", "NUMBER", "LPAR", "MINUS", "PLUS"}), 3, "a value"),
        (frozenset({"PLUS", "MINUS", "STAR", "SLASH", "CIRCUMFLEX"}), 3, "an operator"),
    ]
    for members, minimum, word in groups:
        if len(rest & members) >= minimum:
            words.add(word)
            rest -= members
    words |= {_terminal_word(t) for t in rest}
    ordered = sorted(words, key=lambda w: (_ORDER.index(w) if w in _ORDER else len(_ORDER), w))
    if not ordered:
        return "nothing more"
    return ordered[0] if len(ordered) == 1 else ", ".join(ordered[:-1]) + " or " + ordered[-1]


def _terminal_word(name: str) -> str:
    from .parse import parser

    fixed = {"_NL": "end of line", "$END": "end of file", "UNIT": "a unit", "NAME": "a name",
             "NUMBER": "a number", "STRING": "a quoted description",
             "LOAD_KIND": "'torque' or 'force'", "ON": "'on'", "IN": "'in'"}
    if name in fixed:
        return fixed[name]
    if name in KEYWORD_TERMINALS:
        return f"'{KEYWORD_TERMINALS[name]}'"
    try:
        pattern = parser().get_terminal(name).pattern
    except KeyError:
        return name.lower()
    return f"'{pattern.value}'" if isinstance(pattern, PatternStr) else name.lower()


def _token_span(token: Token, filename: str) -> Span:
    line = token.line or 1
    col = token.column or 1
    if token.type in ("_NL", "$END") or token.end_line != line:
        return Span(filename, line, col, line, col + 1)
    return Span(filename, line, col, line, token.end_column or col + 1)
