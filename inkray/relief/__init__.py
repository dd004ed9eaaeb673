"""Bas-relief meshes (Sýkora et al., "Ink-and-Ray", TOG 2014): completion,
depth order, outlines, triangulation, inflation, stitching and assembly."""
