"""``python -m exoleg.cli``: the ``exoleg`` command."""

from exoleg.cli import console

if __name__ == "__main__":  # not on import (the API reference imports every module)
    raise SystemExit(console())
