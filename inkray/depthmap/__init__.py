"""Depth maps from sparse depth (in)equalities (Sýkora et al., CGF 2010)."""
