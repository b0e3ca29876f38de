"""Small shared helpers: provenance of results, atomic writes, CPU threads."""
