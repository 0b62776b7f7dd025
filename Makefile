# labkit: the two entry points a newcomer needs (see README.md).
#   make reports   install labkit and run the main job on the virtual arm
#   make test      install everything the tests need and run the whole suite
PYTHON ?= python3
PIP = $(PYTHON) -m pip

.PHONY: reports test install install-test firmware

install:
	tools/install-system-deps.sh reports
	$(PIP) install -q -e .

reports: install
	labkit robots
	labkit fk arduino_arm_3dof --deg 45 60 30
	labkit ik arduino_arm_3dof --mm --deg 100 100 -100

install-test:
	tools/install-system-deps.sh test
	$(PIP) install -q -e '.[test,crosscheck]'

test: install-test
	LABKIT_REQUIRE_ALL=1 $(PYTHON) -m pytest -n 2 --dist loadgroup
