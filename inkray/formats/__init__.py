"""Files: each format's reader beside its writer, one convention per artefact,
written atomically."""
