"""Graphs of strict (``a > b``) and non-strict (``a = b``) order relations.

Both methods of inkray check and use their depth relations through these:
the (in)equalities of a depth map (Sýkora et al., CGF 2010) are feasible
exactly when no cycle of relations holds a strict one (:func:`constraint_cycle`),
the fast method gives every segment a level (:meth:`OrderGraph.levels`), and
the relief's local relations (Ink-and-Ray, TOG 2014) are added one at a time,
each refused when it closes such a cycle (:meth:`OrderGraph.path`).
"""

from collections import deque

import numpy as np

__all__ = ["OrderGraph", "constraint_cycle"]


class OrderGraph:
    """Nodes joined by strict edges (front -> back) and equalities (both ways), added one at a time.

    Examples
    --------
    >>> g = OrderGraph()
    >>> g.add("head", "body", label="order[0]")
    >>> g.add("body", "leg", strict=False, label="equal[0]")
    >>> g.path("head", "leg")               # head > body = leg
    [('order[0]', True), ('equal[0]', False)]
    >>> g.path("leg", "head") is None       # so leg > head would close a contradiction
    True
    >>> g.levels()
    {'body': 0, 'head': 1, 'leg': 0}
    """

    def __init__(self):
        self._edges = {}  # node -> [(next node, label, strict)]

    def add(self, front, back, *, strict=True, label=None):
        """Add ``front > back`` (or ``front = back`` when not ``strict``), named ``label``."""
        self._edges.setdefault(front, []).append((back, label, strict))
        self._edges.setdefault(back, [])
        if not strict:
            self._edges[back].append((front, label, False))

    def path(self, start, goal, *, skip=None):
        """A shortest path ``start -> goal`` as ``[(label, strict)]``, or None.

        Parameters
        ----------
        start, goal : node
        skip : callable, optional
            ``skip(label)`` True leaves that edge out.

        Returns
        -------
        list of (label, bool) or None
            Strict edges are followed front to back, equalities either way.
            Adding ``goal > start`` would close a contradictory cycle exactly
            when a path exists; adding ``goal = start`` when one exists with a
            strict edge on it.
        """
        came = {start: None}
        queue = deque([start])
        while queue:
            node = queue.popleft()
            for nxt, label, strict in self._edges.get(node, ()):
                if nxt in came or (skip is not None and skip(label)):
                    continue
                came[nxt] = (node, label, strict)
                if nxt == goal:
                    path = []
                    while came[nxt] is not None:
                        node, label, strict = came[nxt]
                        path.append((label, strict))
                        nxt = node
                    return path[::-1]
                queue.append(nxt)
        return None

    def levels(self):
        """Each node's level: equal nodes share one, ``level(front) >= level(back) + 1``.

        The level is the longest chain of strict relations below a node
        (Kahn's topological sort of the equality classes).

        Returns
        -------
        dict
            ``{node: level}``.

        Raises
        ------
        ValueError
            The relations hold a contradictory cycle.
        """
        parent = {}

        def find(v):
            parent.setdefault(v, v)
            while parent[v] != v:
                parent[v] = parent[parent[v]]
                v = parent[v]
            return v

        nodes = sorted(self._edges, key=repr)
        for u in nodes:
            for v, _, strict in self._edges[u]:
                a, b = find(u), find(v)
                if not strict and a != b:
                    parent[max(a, b, key=repr)] = min(a, b, key=repr)
        classes = sorted({find(v) for v in nodes}, key=repr)
        fronts = {c: [] for c in classes}   # back -> the classes in front of it
        pending = {c: 0 for c in classes}   # strict edges from a class whose back has no level yet
        for u in nodes:
            for v, _, strict in self._edges[u]:
                if strict:
                    fronts[find(v)].append(find(u))
                    pending[find(u)] += 1
        level = {c: 0 for c in classes}
        ready = [c for c in classes if pending[c] == 0]
        done = 0
        while ready:
            c = ready.pop()
            done += 1
            for f in fronts[c]:
                level[f] = max(level[f], level[c] + 1)
                pending[f] -= 1
                if pending[f] == 0:
                    ready.append(f)
        if done != len(classes):
            raise ValueError("the order relations hold a contradictory cycle")
        return {v: level[find(v)] for v in nodes}


def constraint_cycle(p, q, inequality):
    """Find a cycle of constraints that no depth map can satisfy.

    With ``epsilon > 0`` the system of (in)equalities is feasible exactly when
    no closed chain of constraints (equalities walked either way,
    inequalities from front to back) contains an inequality. This is the
    infeasibility test of the exact QP and the cycle test of the fast
    method's region graph (Sýkora et al., CGF 2010).

    Parameters
    ----------
    p, q : (m,) int arrays
        Node indices (``p`` in front for inequalities).
    inequality : (m,) bool array

    Returns
    -------
    list of int
        Constraint indices around one such cycle (starting with the smallest
        inequality index on it), or an empty list when the constraints are
        consistent.

    Examples
    --------
    >>> constraint_cycle([0, 1, 2], [1, 2, 0], [True, False, True])
    [0, 1, 2]
    >>> constraint_cycle([0, 1], [1, 2], [True, True])
    []
    """
    p = [int(v) for v in np.asarray(p).ravel()]
    q = [int(v) for v in np.asarray(q).ravel()]
    ineq = [bool(v) for v in np.asarray(inequality).ravel()]
    m = len(p)
    # Equalities: adjacency for paths inside one equality class.
    eq_adj = {}
    for i in range(m):
        if not ineq[i]:
            eq_adj.setdefault(p[i], []).append((q[i], i))
            eq_adj.setdefault(q[i], []).append((p[i], i))
    comp = {}
    for start in sorted(set(p) | set(q)):
        if start in comp:
            continue
        comp[start] = start
        todo = [start]
        while todo:
            u = todo.pop()
            for v, _ in eq_adj.get(u, ()):
                if v not in comp:
                    comp[v] = start
                    todo.append(v)

    def eq_path(a, b):
        # Constraint indices of an equality path from node a to node b (BFS).
        if a == b:
            return []
        prev = {a: None}
        todo = [a]
        for u in todo:
            for v, i in sorted(eq_adj.get(u, ())):
                if v not in prev:
                    prev[v] = (u, i)
                    todo.append(v)
        path, v = [], b
        while prev[v] is not None:
            u, i = prev[v]
            path.append(i)
            v = u
        return path[::-1]

    # Directed graph of equality classes, one edge per inequality (front -> back).
    out = {}
    for i in range(m):
        if ineq[i]:
            out.setdefault(comp[p[i]], []).append(i)
    for first in range(m):
        if not ineq[first]:
            continue
        # Shortest chain of inequalities from back(first) back to front(first).
        target = comp[p[first]]
        prev = {comp[q[first]]: None}
        todo = [comp[q[first]]]
        found = target in prev
        for u in todo:
            if found:
                break
            for i in out.get(u, ()):
                v = comp[q[i]]
                if v not in prev:
                    prev[v] = (u, i)
                    todo.append(v)
                    if v == target:
                        found = True
                        break
        if not found:
            continue
        chain, v = [], target
        while prev[v] is not None:
            u, i = prev[v]
            chain.append(i)
            v = u
        chain = [first] + chain[::-1]
        cycle = []
        for k, i in enumerate(chain):
            j = chain[(k + 1) % len(chain)]
            cycle.append(i)
            cycle += eq_path(q[i], p[j])
        return cycle  # the smallest inequality on a cycle: a deterministic report
    return []
