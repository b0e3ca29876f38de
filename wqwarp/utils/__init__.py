"""Small shared helpers: provenance of results, atomic writes, validated config dataclasses, CPU threads."""
