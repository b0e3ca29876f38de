"""Command-line plumbing shared by train/ and tools/."""
