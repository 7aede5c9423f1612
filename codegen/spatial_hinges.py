"""A spatial hinge's angle, rate, gradient and gamma (derive's hinge functions), derived once
per kind of hinge: hinges whose members are of the same kinds, with the same sign, offset and
middle of travel and the same pattern of named constants (a number where a constant is one)
give the same expressions but for their symbols, so the first of a kind is derived and the
others are its expressions renamed (the roles of codegen/blocks.py)."""

from __future__ import annotations

import sympy

from depsim.dsl import ir

from .assembly import Group
from .blocks import member_roles, named_roles, renamed
from .spatial import SpatialKinematics, cross, dot, times

# (d theta/dq as coordinate index -> entry, theta, theta', gamma, the hinge's steps)
HingeParts = tuple[dict[int, sympy.Expr], sympy.Expr, sympy.Expr, sympy.Expr,
                   tuple[Group, ...]]


class HingeDerivatives:
    """The hinges' parts (`of`), each kind derived once (module docstring); every hinge's
    steps land in kin.hinge_steps."""

    def __init__(self, kin: SpatialKinematics):
        self.kin = kin
        self._rates = dict(zip(kin.symbols.q, kin.symbols.qd))
        self._column = {s: j for j, s in enumerate(kin.symbols.q)}
        self._derived: dict[tuple, tuple | None] = {}

    def of(self, index: int) -> tuple[dict[int, sympy.Expr], sympy.Expr, sympy.Expr,
                                       sympy.Expr]:
        """(d theta/dq, theta, theta', -(d theta/dq qd)_q qd) of hinge `index` (_derive)."""
        kin, hinge = self.kin, self.kin.model.hinges[index]
        key = self._key(index)
        template = self._derived.get(key)
        if template is None:
            parts = _derive(kin, index)
            if key not in self._derived:
                self._derived[key] = self._template(index, parts)
        else:
            back = {x: symbol for symbol, x in self._member_roles(hinge)}
            back.update({x: sympy.Symbol(f"@{hinge.name}.{x.name[3:]}") for x in template[-1]})
            gradient, theta, rate, gamma, steps = (_rename(part, back)
                                                   for part in template[:-1])
            gradient = {self._column[back[x]]: g for x, g in gradient.items()}
            parts = (dict(sorted(gradient.items())), theta, rate, gamma, steps)
        kin.hinge_steps[index] = parts[4]
        return parts[:4]

    def _member_roles(self, hinge: ir.Hinge) -> list:
        roles = []
        for side, member in zip("ab", (hinge.a.member, hinge.b.member)):
            if member.kind is not ir.MemberKind.GROUND:
                coordinates = self.kin.member_symbols(member)
                roles += member_roles(side, coordinates, [self._rates[s] for s in coordinates])
        return roles

    def _key(self, index: int) -> tuple:
        """What a hinge's parts are a function of, but its symbols: its members' kinds, sign,
        offset, middle of travel and its vectors' named constants (as placeholders)."""
        kin, hinge = self.kin, self.kin.model.hinges[index]
        s_a, s_b, axis, turned = kin._turn_vectors(index, kin.hinge_near(index))
        inputs = (s_a, s_b, axis, turned(sympy.Integer(1), sympy.Integer(0)))
        roles = dict(named_roles({x for vector in inputs for x in vector
                                  if isinstance(x, sympy.Symbol)}, (f"{hinge.name}.",)))
        return (hinge.a.member.kind, hinge.b.member.kind, hinge.sign,
                kin.hinge_near(index), kin.const(hinge.offset),
                tuple(tuple(renamed(x, roles) for x in vector)
                      for vector in inputs))

    def _template(self, index: int, parts: HingeParts) -> tuple | None:
        """The parts over placeholders and the named placeholders they use; None when a
        symbol of the hinge's own would stay in them (then each hinge of the kind is derived
        as it is)."""
        kin, hinge = self.kin, self.kin.model.hinges[index]
        gradient, theta, rate, gamma, steps = parts
        symbols = set().union(*(value.free_symbols for value in (theta, rate, gamma)),
                              *(g.free_symbols for g in gradient.values()),
                              *({s} | v.free_symbols for group in steps for s, v in group))
        roles = dict(self._member_roles(hinge) + named_roles(symbols, (f"{hinge.name}.",)))
        template = tuple(_rename(part, roles) for part in (theta, rate, gamma, steps))
        grad = {roles[kin.symbols.q[j]]: g.xreplace(roles) for j, g in gradient.items()}
        free = set().union(*(_free(part) for part in template),
                           *(g.free_symbols for g in grad.values()))
        parameters = set(kin.p)
        if any(not x.name.startswith("#") and x not in parameters for x in free):
            return None
        named = frozenset(x for x in free | {s for group in template[3] for s, _ in group}
                          if x.name.startswith("#c."))
        return (grad, *template, named)


def _rename(part, names: dict):
    """An expression, a gradient (placeholder -> entry: the entries renamed) or steps."""
    if isinstance(part, dict):
        return {x: value.xreplace(names) for x, value in part.items()}
    if isinstance(part, tuple):
        return tuple(tuple((s.xreplace(names), v.xreplace(names)) for s, v in group)
                     for group in part)
    return part.xreplace(names)


def _free(part) -> set:
    if isinstance(part, tuple):
        return set().union(*(v.free_symbols for group in part for _, v in group))
    return part.free_symbols


def _derive(kin: SpatialKinematics, index: int) -> HingeParts:
    """(d theta/dq as coordinate index -> entry, theta, theta', -(d theta/dq qd)_q qd)
    of a hinge, from theta = sign (near + atan2(S, C)) + offset written out: with
    D = S^2 + C^2 and dots the rates along qd, theta' = sign (C S' - S C')/D and

        -(theta'_q qd) = -sign ((C S'' - S C'') D - 2 (C S' - S C') (S S' + C C')) / D^2,

    S'' = (S'_q qd) (S is bilinear in q, so these stay small where sympy's derivatives of
    atan2 would not). S and C are the triple product [u, w, n] and u . w of vectors
    linear in q (u = R_A s_A, w = R_B s_B, n = R_A a; hinge_turn_parts), so their
    derivatives come from the product rule on those vectors (u'' = 0 along qd), not from
    differentiating the expressions written out: d u / d R_A[i, j] = s_A[j] e_i, and

        [u, w, n]'  = [u', w, n] + [u, w', n] + [u, w, n'],
        [u, w, n]'' = 2 ([u', w', n] + [u', w, n'] + [u, w', n']).

    The vectors, S, C, D and their rates are named steps (`hinge_steps`, in the order
    they depend on each other), so every expression here is a few terms of those names:
    written out, each gradient entry repeated S and C whole and the generated hinge
    functions' CSE had to find them again."""
    hinge = kin.model.hinges[index]
    s_a, s_b, axis, turned = kin._turn_vectors(index, kin.hinge_near(index))
    ra, rb = kin.rotation(hinge.a.member), kin.rotation(hinge.b.member)
    rate_a, rate_b = kin._rotation_rate(hinge.a.member), kin._rotation_rate(hinge.b.member)
    steps: list[list[tuple[sympy.Symbol, sympy.Expr]]] = []

    def level(**parts) -> dict:
        """Name each part (a vector or a scalar) as steps of one new group."""
        group: list[tuple[sympy.Symbol, sympy.Expr]] = []

        def name(label: str, value: sympy.Expr) -> sympy.Expr:
            if value.is_Atom:  # a number or a name already: nothing to compute
                return value
            symbol = sympy.Symbol(f"@{hinge.name}.{label}")
            group.append((symbol, value))
            return symbol

        named = {key: tuple(name(f"{key}_{axis}", component)
                            for axis, component in zip("xyz", value))
                 if isinstance(value, tuple) else name(key, value)
                 for key, value in parts.items()}
        if group:
            steps.append(group)
        return named

    v = level(u=times(ra, s_a), w=times(rb, s_b), n=times(ra, axis),
              du=times(rate_a, s_a), dw=times(rate_b, s_b), dn=times(rate_a, axis))
    u, w, n, du, dw, dn = (v[key] for key in ("u", "w", "n", "du", "dw", "dn"))
    v.update(level(wn=cross(w, n), nu=cross(n, u), uw=cross(u, w), C0=dot(u, w),
                   rate_C0=dot(du, w) + dot(u, dw), second_C0=2 * dot(du, dw),
                   second_S0=2 * (dot(cross(du, dw), n) + dot(cross(du, w), dn)
                                  + dot(cross(u, dw), dn))))
    wn, nu, uw = v["wn"], v["nu"], v["uw"]
    v.update(level(S0=dot(uw, n), rate_S0=dot(du, wn) + dot(dw, nu) + dot(dn, uw)))
    sine, cosine = turned(v["S0"], v["C0"])
    rate_s, rate_c = turned(v["rate_S0"], v["rate_C0"])
    second_s, second_c = turned(v["second_S0"], v["second_C0"])
    v.update(level(S=sine, C=cosine, rate_S=rate_s, rate_C=rate_c, second_S=second_s,
                   second_C=second_c))
    sine, cosine, rate_s, rate_c = v["S"], v["C"], v["rate_S"], v["rate_C"]
    v.update(level(D=sine**2 + cosine**2, rate_numerator=cosine * rate_s - sine * rate_c))
    size, numerator = v["D"], v["rate_numerator"]
    # d/dR_A[i, j] moves u and n (by s_A[j] e_i and a[j] e_i), d/dR_B[i, j] moves w
    partials = ((hinge.a.member, lambda i, j: (wn[i] * s_a[j] + uw[i] * axis[j],
                                               w[i] * s_a[j])),
                (hinge.b.member, lambda i, j: (nu[i] * s_b[j], u[i] * s_b[j])))
    gradient = {}
    for member, partial in partials:
        if member.kind is not ir.MemberKind.BODY:
            continue
        start = 12 * member.index + 3  # its R11 (body_symbols)
        for i in range(3):
            for j in range(3):
                grad_s, grad_c = turned(*partial(i, j))
                gradient[start + 3 * i + j] = \
                    hinge.sign * (cosine * grad_s - sine * grad_c) / size
    gradient = {j: g for j, g in sorted(gradient.items()) if g != 0}
    gamma = -hinge.sign * ((cosine * v["second_S"] - sine * v["second_C"]) * size
                           - 2 * numerator * (sine * rate_s + cosine * rate_c)) / size**2
    theta = hinge.sign * (kin.hinge_near(index) + sympy.atan2(sine, cosine)) \
        + kin.const(hinge.offset)
    return gradient, theta, hinge.sign * numerator / size, gamma, tuple(map(tuple, steps))