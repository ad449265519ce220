"""``python -m satfmu.sims.robustness``: the suite's command line (also the workers' entry point)."""
import sys

from satfmu.sims.robustness.command import main

sys.exit(main())
