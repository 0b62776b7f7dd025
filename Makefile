# labkit: the two entry points a newcomer needs (see README.md).
#   make reports   install labkit and run the main job on the virtual arm
#   make test      install everything the tests need and run the whole suite
PYTHON ?= python3
PIP = $(PYTHON) -m pip

.PHONY: reports test install install-test firmware

install:
	tools/install-system-deps.sh reports
	$(PIP) install -q -e .

# every lab notebook executed against the simulated arm (sim://), its HTML + reports/index.html,
# then one hand-in report per lab (reports/<lab>.pdf + .html) from the notebooks just executed;
# a PDF per notebook too: labkit render --pdf (its default) instead of --no-pdf
reports: install
	$(PYTHON) -m labkit render --no-pdf --jobs 2 --output reports
	for lab in notebooks/*/; do \
	  name=$$(basename $$lab); \
	  $(PYTHON) -m labkit report $$lab --executed reports/$$name --output reports/ || exit 1; \
	done

# the Arduino firmware (hex + ELF) and the simavr harness; prints flash/SRAM use
firmware:
	$(MAKE) -C firmware

install-test:
	tools/install-system-deps.sh test
	$(PIP) install -q -e '.[test,crosscheck]'

test: install-test
	LABKIT_REQUIRE_ALL=1 $(PYTHON) -m pytest -n 2 --dist loadgroup
