"""``python -m satfmu.sims.robustness``: the suite's command line (also the workers' entry point)."""
import sys

from satfmu.sims.robustness.command import main

if __name__ == "__main__":  # importing the module (a documentation build) runs nothing
    sys.exit(main())
