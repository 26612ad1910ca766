"""``python -m remote_trigger.pywrap.cli``: the same as the ``remote-trigger`` command."""
import sys

from remote_trigger.pywrap.cli import main

if __name__ == "__main__":
    sys.exit(main())
