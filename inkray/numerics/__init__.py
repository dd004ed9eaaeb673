"""Numerics with no inkray concepts: sparse SPD solves, grid Laplacians, the
grid Cholesky, the dual active-set QP, order graphs and polyline geometry."""
