"""LastCall: a repeated call is answered from memory, a new one is not, and derivatives are the
inner function's own (checked against a function whose value and gradient are known in closed form)."""

import casadi as cs
import numpy as np

from judgeopt.judge.compiled import LastCall


class Counted(cs.Callback):
    """f(x) = [sum(x^2), sum(x)] for a 1 x 3 row, counting its evaluations; reverse sweep exact."""

    def __init__(self) -> None:
        cs.Callback.__init__(self)
        self.calls = 0
        self.construct("counted", {})

    def get_n_in(self) -> int:
        return 1

    def get_n_out(self) -> int:
        return 1

    def get_sparsity_in(self, i: int) -> cs.Sparsity:
        return cs.Sparsity.dense(1, 3)

    def get_sparsity_out(self, i: int) -> cs.Sparsity:
        return cs.Sparsity.dense(1, 2)

    def eval(self, args: list) -> list:
        self.calls += 1
        x = np.asarray(args[0]).ravel()
        return [cs.DM([[float(x @ x), float(x.sum())]])]

    def has_reverse(self, nadj: int) -> bool:
        return nadj == 1

    def get_reverse(self, nadj: int, name: str, inames: list, onames: list, opts: dict) -> cs.Function:
        x, out, seed = cs.MX.sym("x", 1, 3), cs.MX.sym("out", 1, 2), cs.MX.sym("seed", 1, 2)
        return cs.Function(name, [x, out, seed], [seed[0, 0] * 2 * x + seed[0, 1]], inames, onames)


def test_a_repeated_call_is_answered_from_memory_and_a_new_one_is_not():
    inner = Counted()
    last = LastCall(inner)
    x = cs.DM([[1.0, 2.0, 3.0]])
    first = last(x)
    assert inner.calls == 1
    assert np.array_equal(np.asarray(last(x)), np.asarray(first)) and inner.calls == 1
    assert np.allclose(np.asarray(last(cs.DM([[1.0, 2.0, 4.0]]))), [[21.0, 7.0]]) and inner.calls == 2
    assert np.allclose(np.asarray(last(x)), [[14.0, 6.0]]) and inner.calls == 3  # memory holds one call


def test_values_and_gradients_through_it_are_the_inner_functions_and_the_jacobian_reuses_the_value():
    inner = Counted()
    last = LastCall(inner)
    x = cs.MX.sym("x", 3)
    g = last(x.T)[0, 0] + 3 * last(x.T)[0, 1]  # sum(x^2) + 3 sum(x): gradient 2x + 3
    value = cs.Function("g", [x], [g])
    jac = cs.Function("jac_g", [x], [g, cs.gradient(g, x)])
    point = np.array([0.5, -1.0, 2.0])
    assert float(value(point)) == 0.25 + 1.0 + 4.0 + 3 * 1.5
    calls = inner.calls
    v, grad = jac(point)
    assert inner.calls == calls  # the forward pass the Jacobian needs came from memory
    assert float(v) == float(value(point))
    assert np.allclose(np.asarray(grad).ravel(), 2 * point + 3)
    jac(point)
    assert inner.calls == calls
