"""The additive Runge-Kutta method ark548 (docs/model.md §8.2): the coefficients of ARK5(4)8L[2]SA satisfy the
order conditions of an additive pair (every rooted tree up to order 5 with each edge taken from either tableau,
so each tableau alone and every coupling of the two), its embedded weights those up to order 4, and under the
pressure tables (no chamber states) it is the explicit tableau alone."""
import itertools
import math

import numpy as np
import pytest

from rotary_vane.mechanics import CompressorParameters, Simulation, constant_speed
from rotary_vane.mechanics.loop.ark548_tableau import (ARK_B, ARK_B_HAT, ARK_C, ARK_EXPLICIT, ARK_GAMMA,
                                                      ARK_IMPLICIT, ARK_STAGES)
from rotary_vane.mechanics.loop.integrators import ACCEPTED, EVALUATIONS, JACOBIANS, NEWTON_ITERATIONS

TABLEAUX = (ARK_EXPLICIT, ARK_IMPLICIT)
COEFFICIENT_ACCURACY = 1e-11      # the published coefficients are 13-digit rationals


def rooted_trees(order):
    """Every rooted tree with `order` vertices, as a sorted tuple of its subtrees (children)."""
    if order == 1:
        return [()]
    trees = set()
    for children in _forests(order - 1):
        trees.add(tuple(sorted(children)))
    return sorted(trees)


def _forests(vertices, smallest=1):
    """Multisets of trees with `vertices` vertices in all (as lists, subtree sizes non-decreasing)."""
    if vertices == 0:
        return [[]]
    forests = []
    for size in range(smallest, vertices + 1):
        for tree in rooted_trees(size):
            for rest in _forests(vertices - size, size):
                forests.append([tree, *rest])
    return forests


def size(tree):
    return 1 + sum(size(child) for child in tree)


def density(tree):
    """gamma(t) = |t| prod gamma(children): the exact solution's elementary weight is 1/gamma(t)."""
    return size(tree) * math.prod(density(child) for child in tree)


def stage_weights(tree, colouring):
    """The vector Phi_i(t) of a tree whose edges take their matrix from `colouring` (one tableau per edge, in
    depth-first order): Phi(t) = prod over children of A_colour (Phi(child))."""
    weights = np.ones(ARK_STAGES)
    position = 0
    for child in tree:
        matrix = TABLEAUX[colouring[position]]
        child_edges = size(child) - 1
        weights = weights * (matrix @ stage_weights(child, colouring[position + 1:position + 1 + child_edges]))
        position += 1 + child_edges
    return weights


def coloured_conditions(max_order):
    for order in range(1, max_order + 1):
        for tree in rooted_trees(order):
            for colouring in itertools.product(range(len(TABLEAUX)), repeat=order - 1):
                yield tree, colouring


def test_the_trees_are_counted_right():
    """1, 1, 2, 4, 9 rooted trees of order 1..5 (17 classical conditions for order 5)."""
    assert [len(rooted_trees(order)) for order in range(1, 6)] == [1, 1, 2, 4, 9]


def test_the_tableaux_have_their_structure():
    """Explicit tableau strictly lower triangular, ESDIRK with an explicit first stage and gamma on the diagonal,
    stiffly accurate (its last row is b); both have the nodes c as row sums."""
    assert np.all(np.triu(ARK_EXPLICIT) == 0.0)
    assert np.all(np.triu(ARK_IMPLICIT, 1) == 0.0) and ARK_IMPLICIT[0, 0] == 0.0
    assert np.all(np.diag(ARK_IMPLICIT)[1:] == ARK_GAMMA)
    np.testing.assert_array_equal(ARK_IMPLICIT[-1], ARK_B)
    for matrix in TABLEAUX:
        np.testing.assert_allclose(matrix.sum(axis=1), ARK_C, atol=COEFFICIENT_ACCURACY)


@pytest.mark.parametrize("weights, order", [(ARK_B, 5), (ARK_B_HAT, 4)], ids=["b order 5", "b_hat order 4"])
def test_the_additive_order_conditions_hold(weights, order):
    """b . Phi(t) = 1/gamma(t) for every rooted tree up to the order and every choice of tableau per edge (the
    classical conditions of each tableau and the coupling conditions of the pair)."""
    residuals = {(tree, colouring): weights @ stage_weights(tree, colouring) - 1.0 / density(tree)
                 for tree, colouring in coloured_conditions(order)}
    worst = max(residuals, key=lambda key: abs(residuals[key]))
    assert abs(residuals[worst]) <= COEFFICIENT_ACCURACY, (worst, residuals[worst])


def test_the_embedded_weights_are_not_fifth_order():
    """The error estimate b - b_hat is not zero on the 5th-order trees (else it would estimate nothing)."""
    assert max(abs((ARK_B - ARK_B_HAT) @ stage_weights(tree, (0,) * (size(tree) - 1)))
               for tree in rooted_trees(5)) > 1e-4


def test_under_the_pressure_table_it_is_the_explicit_tableau_alone():
    """Level 0.5 has no chamber states: no Newton iteration, no Jacobian, 8 right-hand sides per attempted step,
    and the same motion as Dormand-Prince to the tolerance."""
    runs = {}
    for method in ("ark548", "dopri5"):
        params = CompressorParameters(pressure_model="ideal_gas_table", integrator=method)
        simulation = Simulation(params, constant_speed(1500.0), keep_history=False)
        simulation.advance(0.004)
        runs[method] = simulation
    counters = runs["ark548"].counters
    assert counters[NEWTON_ITERATIONS] == 0 and counters[JACOBIANS] == 0
    assert counters[EVALUATIONS] >= 8 * counters[ACCEPTED]
    np.testing.assert_allclose(runs["ark548"].state[:6], runs["dopri5"].state[:6], rtol=1e-3, atol=1e-6)
