"""``python -m exoleg.cli``: the ``exoleg`` command."""

from exoleg.cli import console

raise SystemExit(console())
