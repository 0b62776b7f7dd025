# labkit: the two entry points a newcomer needs (see README.md).
#   make reports   install labkit and run the main job on the virtual arm
#   make test      install everything the tests need and run the whole suite
#
# Python environment: the active virtualenv when there is one ($VIRTUAL_ENV), otherwise the project's own
# .venv/, made here with $(BASE_PYTHON) -m venv (a distribution's python3, e.g. Debian 12's or Ubuntu 24.04's,
# is "externally managed" (PEP 668): pip refuses to install into it). Afterwards: .venv/bin/labkit, or
# `. .venv/bin/activate` and then labkit.
BASE_PYTHON ?= python3
ifdef VIRTUAL_ENV
VENV ?= $(VIRTUAL_ENV)
else
VENV ?= $(CURDIR)/.venv
endif
PYTHON = $(VENV)/bin/python
PIP = $(PYTHON) -m pip
# the recipes run as in an activated venv: `python`, `labkit` and `jupyter` found by name are the venv's
export PATH := $(VENV)/bin:$(PATH)
export VIRTUAL_ENV := $(VENV)

.PHONY: reports test install install-test venv pip firmware

# a virtualenv to install into (none is made when one is active); Debian/Ubuntu need python3.X-venv for it
$(VENV)/bin/python:
	tools/install-system-deps.sh venv $(BASE_PYTHON)
	$(BASE_PYTHON) -m venv $(VENV)

venv: $(VENV)/bin/python

# pip inside that environment: an active one made without it (`python -m venv --without-pip`, `uv venv`) gets it
# from ensurepip (which Debian/Ubuntu ship in python3.X-venv)
pip: venv
	$(PYTHON) -m pip --version >/dev/null 2>&1 || \
	  { tools/install-system-deps.sh venv $(PYTHON) && $(PYTHON) -m ensurepip --upgrade --default-pip; }

# labkit with every extra: notebooks and reports, JupyterLab, the course tools, the camera, servo buses, URDF.
# Editable through a path entry (editable_mode=compat), not an import hook: from the clone's parent folder, where
# Python sees the clone's own folder "labkit" as a namespace package, `from labkit import Robot` still works
EDITABLE = --config-settings editable_mode=compat -e
install: pip
	tools/install-system-deps.sh reports
	$(PIP) install -q $(EDITABLE) '.[all]'

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

install-test: pip
	tools/install-system-deps.sh test
	$(PIP) install -q $(EDITABLE) '.[all,test,crosscheck]'

test: install-test
	LABKIT_REQUIRE_ALL=1 $(PYTHON) -m pytest -n 2 --dist loadgroup
