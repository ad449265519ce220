"""``python -m sims.robustness``: the suite's command line (also the workers' entry point)."""
import sys

from sims.robustness.command import main

sys.exit(main())
