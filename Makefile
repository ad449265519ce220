# satfmu: `make demo` and `make test` do all set-up on a fresh Python 3.11 machine.
# Each stage prints one line (wall and CPU time, last line of its output); its full output is
# in build/logs/ (scripts/stage.sh). `make verify` runs every scenario in every engine.
PYTHON ?= python3.11
VENV := .venv
PY := $(VENV)/bin/python
SATFMU := $(VENV)/bin/satfmu
STAGE := scripts/stage.sh
FMU_DIR := build/fmus
SCENARIOS := mrp_200deg mrp_200deg_sat mrp_320deg_sat mrp_eq44 mrp_200deg_synth mrp_320deg_sat_synth mrp_eq44_synth mrp_90deg_h2 mrp_200deg_h2hinf mrp_320deg_sat_h2hinf mrp_eq44_h2hinf vscmg_seed vscmg_seed_friction cubesat_detumble demeter_row1_det_both demeter_row1_det_theta demeter_row1_det_rate
# the demo's verification: seed 000's and seed 001's loops, the cubesat detumbling and seed 002's
# manoeuvre with its native online SDRE controllers (seconds each; every scenario: `make verify`)
VERIFY_SHORT := mrp_200deg mrp_90deg_h2 cubesat_detumble vscmg_seed
# the demo's Monte Carlo: seed 000's two controllers and seed 001's over the same random attitudes and
# inertias (their [campaign] demo size), then one report page of them and the 200 deg run
DEMO_CAMPAIGNS := mrp_slew_mc mrp_slew_mc_synth mrp_slew_mc_h2hinf

# uv (a PyPI package, installed by pip into the venv) installs the dependencies in about 7 s where pip
# takes 35 s (pip is the fallback when uv fails); neither byte-compiles the ~9,000 modules of the
# dependencies: Python compiles a module on its first import and keeps it, which
# PYTHONDONTWRITEBYTECODE (set on some machines) would forbid, so make's commands run without it.
unexport PYTHONDONTWRITEBYTECODE

.PHONY: demo test test-all lint docs build validate verify bench clean system-deps browser-deps wine-deps bench-deps

# Debian's libtbb12 is needed by the ecos co-simulation host (ecospy), and its MinGW-w64 cross compiler
# (x86_64-w64-mingw32-gcc) builds every native FMU's win64 DLL; installed once, guarded, checked again
# when this Makefile changes.
system-deps: $(VENV)/.system-deps
$(VENV)/.system-deps: Makefile
	@mkdir -p $(VENV)
	@if ldconfig -p 2>/dev/null | grep -q 'libtbb.so.12'; then :; \
	elif command -v apt-get >/dev/null 2>&1 && [ "$$(id -u)" = 0 ]; then \
	  (apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq libtbb12 >/dev/null 2>&1) \
	  || { echo "error: apt-get could not install libtbb12 (needed by the ecos FMU host)"; exit 1; }; \
	else echo "error: libtbb12 is missing; install Debian's libtbb12 (needed by the ecos FMU host)"; exit 1; fi
	@if command -v x86_64-w64-mingw32-gcc >/dev/null 2>&1; then :; \
	elif command -v apt-get >/dev/null 2>&1 && [ "$$(id -u)" = 0 ]; then \
	  echo "installing Debian's gcc-mingw-w64-x86-64-posix (the cross compiler of the native FMUs' win64 DLLs)"; \
	  (apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends \
	    gcc-mingw-w64-x86-64-posix >/dev/null 2>&1) \
	  || { echo "error: apt-get could not install gcc-mingw-w64-x86-64-posix (needed to build the native FMUs' win64 DLLs)"; exit 1; }; \
	else echo "error: x86_64-w64-mingw32-gcc is missing and apt-get cannot install it here (not Debian, or not root): install Debian's gcc-mingw-w64-x86-64-posix (or -win32), the MinGW-w64 cross compiler that builds the native FMUs' win64 DLLs"; exit 1; fi
	@command -v gcc >/dev/null || { echo "error: gcc is needed to compile the native FMUs"; exit 1; }
	@touch $@

# Debian's chromium and chromium-driver: the report page's browser test (tests/test_report.py) opens
# the page in them. Checked on every `make test`, installed when missing (about 23 s with apt-get).
browser-deps:
	@if command -v chromium >/dev/null 2>&1 && command -v chromedriver >/dev/null 2>&1; then :; \
	elif command -v apt-get >/dev/null 2>&1 && [ "$$(id -u)" = 0 ]; then \
	  echo "installing Debian's chromium and chromium-driver (the report page's browser test)"; \
	  (apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq chromium chromium-driver >/dev/null 2>&1) \
	  || { echo "error: apt-get could not install chromium and chromium-driver (needed by the report page's browser test)"; exit 1; }; \
	else echo "error: chromium or chromedriver is missing and apt-get cannot install them here (not Debian, or not root): install Debian's chromium and chromium-driver, or your system's Chromium and its ChromeDriver on PATH (needed by the report page's browser test, tests/test_report.py)"; exit 1; fi

# Debian's wine64 (wine 8 on bookworm): the slow test that runs every native FMU's win64 DLL under wine
# beside its linux64 library (tests/test_win64.py). Checked on every `make test-all`, installed when
# missing (about 21 s with apt-get).
wine-deps:
	@if command -v wine64 >/dev/null 2>&1 || [ -x /usr/lib/wine/wine64 ]; then :; \
	elif command -v apt-get >/dev/null 2>&1 && [ "$$(id -u)" = 0 ]; then \
	  echo "installing Debian's wine64 (the win64 FMU binaries' test under wine)"; \
	  (apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq wine64 >/dev/null 2>&1) \
	  || { echo "error: apt-get could not install wine64 (needed by the win64 test under wine)"; exit 1; }; \
	else echo "error: wine64 is missing and apt-get cannot install it here (not Debian, or not root): install Debian's wine64, or your system's 64-bit wine with wine64 on PATH (needed by the win64 test under wine, tests/test_win64.py)"; exit 1; fi

$(VENV)/.installed: pyproject.toml | system-deps
	@command -v $(PYTHON) >/dev/null || { echo "error: $(PYTHON) not found (Python 3.11 is required)"; exit 1; }
	@$(STAGE) install sh -c 'set -e; test -x $(PY) || $(PYTHON) -m venv $(VENV); \
	  $(PY) -m pip install -q --no-compile "uv>=0.4"; \
	  $(VENV)/bin/uv pip install -q --python $(PY) -e ".[test]" || $(PY) -m pip install -q --no-compile -e ".[test]"; \
	  chmod +x "$$($(PY) -c "import importlib.util, pathlib; print(pathlib.Path(importlib.util.find_spec(\"ecospy\").origin).parent / \"binaries\" / \"ecos\")")"; \
	  echo "satfmu and its dependencies installed in $(VENV)"'
	@# (ecospy's wheel ships its host binary without the executable bit: chmod above)
	@touch $@

build: $(VENV)/.installed
	@$(STAGE) "build FMUs" $(SATFMU) build --fmu-dir $(FMU_DIR)

validate: build
	@$(STAGE) validate $(SATFMU) validate --fmu-dir $(FMU_DIR)

demo: build
	@$(STAGE) validate $(SATFMU) validate --fmu-dir $(FMU_DIR)
	@$(STAGE) scenarios $(SATFMU) run $(SCENARIOS) --fmu-dir $(FMU_DIR) --out results --summary results/summary.json --plot
	@$(STAGE) "pythonfmu run" $(SATFMU) run mrp_200deg --backend python --fmu-dir $(FMU_DIR) --out results --plot
	@$(STAGE) detumble $(SATFMU) detumble --fmu-dir $(FMU_DIR) --out results/cubesat
	@$(STAGE) "verify (short)" $(SATFMU) verify $(VERIFY_SHORT) --fmu-dir $(FMU_DIR) --out results/verify
	@mkdir -p results/campaigns
	@$(STAGE) campaigns sh -c 'for s in $(DEMO_CAMPAIGNS); do rm -rf results/campaigns/$$s-demo; \
	  $(SATFMU) campaign scenario $$s --demo --name $$s-demo --fmu-dir $(FMU_DIR) --out results/campaigns \
	  >results/campaigns/$$s-demo.txt 2>results/campaigns/$$s-demo.err \
	  || [ $$? -eq 1 ] || { cat results/campaigns/$$s-demo.err; exit 2; }; \
	  sed -n 3p results/campaigns/$$s-demo.txt | sed "s/^all metrics (passed) */$$s: /; s/ *$$//"; done'
	@$(STAGE) report $(SATFMU) report $(foreach s,$(DEMO_CAMPAIGNS),results/campaigns/$(s)-demo) results/mrp_200deg \
	  --out results/report.html
	@$(STAGE) "co-sim speed" $(PY) bench/cosim_speed.py --fmu-dir $(FMU_DIR)
	@echo
	@cat results/summary.md
	@echo
	@sed -n '/^closed loop/,$$p' build/logs/co-sim_speed.log
	@echo
	@echo "Monte Carlo, random attitudes and inertia +-20 %, samples within every bound (Clopper-Pearson 95 %):"
	@cat build/logs/campaigns.log
	@echo "plots, CSV and summaries (results/summary.md, results/summary.json) are in results/, the campaigns in"
	@echo "results/campaigns/, their report page in results/report.html; logs in build/logs/"

verify: build
	@$(STAGE) --show verify $(SATFMU) verify --fmu-dir $(FMU_DIR) --out results/verify

# one pytest worker per CPU, a test file per worker (its module fixtures are solved once), one BLAS
# thread per worker (spinning BLAS pools of two workers oversubscribe the CPUs)
PYTEST := env OPENBLAS_NUM_THREADS=1 OMP_NUM_THREADS=1 MKL_NUM_THREADS=1 $(PY) -m pytest -q -n auto --dist loadfile

# the code's habits, configured in pyproject.toml: ruff (style and pyflakes), zero findings; mypy on
# satfmu as installed, zero errors outside the modules whose hidden errors pyproject.toml counts
lint: $(VENV)/.installed
	@$(STAGE) ruff $(VENV)/bin/ruff check .
	@$(STAGE) mypy $(PY) scripts/typecheck.py

# the documentation site: README walkthrough, docs/*.md and the API reference from the docstrings, in
# build/docs (open build/docs/index.html); nitpicky, every warning an error (tests/test_docs.py builds it too)
docs: $(VENV)/.installed
	@$(STAGE) docs $(VENV)/bin/sphinx-build -q -W --keep-going -n -b html docs build/docs

# the FMU build and mypy run side by side (the build leaves a core partly idle)
test: browser-deps $(VENV)/.installed
	@$(MAKE) --no-print-directory -j2 build lint
	@$(STAGE) --show tests $(PYTEST)

# the bench extra (Drake, SumOfSquares.py, Basilisk): `make test-all` runs the tests that pose our SOS
# programs in Drake (tests/test_sos_bench.py) and check the plants against Basilisk (tests/test_basilisk.py),
# each skipped without it; `make bench` compares with all three
bench-deps: $(VENV)/.bench-deps
$(VENV)/.bench-deps: pyproject.toml | $(VENV)/.installed
	@mkdir -p build/logs
	@{ $(VENV)/bin/uv pip install -q --python $(PY) -e '.[test,bench]' \
	  || $(PY) -m pip install -q --no-compile -e '.[test,bench]'; } >build/logs/bench-install.log 2>&1 \
	  || { cat build/logs/bench-install.log; exit 1; }
	@touch $@

test-all: build browser-deps wine-deps bench-deps
	@$(STAGE) --show "tests (all)" $(PYTEST) -m "slow or not slow"

bench: build bench-deps
	$(PY) bench/cli_startup.py
	$(PY) bench/build_speed.py
	$(PY) bench/fresh_clone.py
	$(PY) bench/cosim_speed.py --fmu-dir $(FMU_DIR)
	$(PY) bench/sos_speed.py
	$(PY) bench/sos_symmetry.py
	$(PY) bench/sdre_speed.py
	$(PY) bench/basilisk_compare.py

clean:
	rm -rf build results .pytest_cache
