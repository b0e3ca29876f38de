"""One-off studies: each a script that measures one question once and writes its result under
``docs/studies/<name>/`` (the ``docs/`` pages cite them)."""
