import pytest

from inkray.numerics.order_graph import OrderGraph, constraint_cycle


def test_levels_are_longest_chains_with_equal_nodes_sharing():
    g = OrderGraph()
    for front, back in [(3, 2), (2, 1), (3, 1), (5, 4)]:
        g.add(front, back)
    g.add(4, 1, strict=False)
    assert g.levels() == {1: 0, 2: 1, 3: 2, 4: 0, 5: 1}


def test_a_contradiction_is_a_path_back_and_levels_refuse_it():
    g = OrderGraph()
    g.add("a", "b", label=0)
    g.add("b", "c", strict=False, label=1)
    assert g.path("c", "a") is None            # a > b = c: nothing leads from c back to a
    assert g.path("a", "c") == [(0, True), (1, False)]
    assert g.path("a", "c", skip=lambda label: label == 1) is None
    g.add("c", "a", label=2)
    with pytest.raises(ValueError, match="cycle"):
        g.levels()


def test_constraint_cycle_needs_a_strict_edge():
    assert constraint_cycle([0, 1], [1, 0], [False, False]) == []
    assert constraint_cycle([0, 1], [1, 0], [True, False]) == [0, 1]
    assert constraint_cycle([0, 1, 2], [1, 2, 3], [True, True, True]) == []
