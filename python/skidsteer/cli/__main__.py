"""``python -m skidsteer.cli``: the `skidsteer` command."""
import sys

from skidsteer.cli import main

sys.exit(main())
