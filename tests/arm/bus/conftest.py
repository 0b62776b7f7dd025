"""Robot files of the bus tests: a 4-joint arm on a Dynamixel bus and the same arm on a Feetech bus."""

from pathlib import Path

import pytest

HERE = Path(__file__).parent
ROBOTS = {"dynamixel": str(HERE / "omx_test.toml"), "feetech": str(HERE / "so101_test.toml")}


@pytest.fixture(params=sorted(ROBOTS))
def kind(request):
    return request.param


@pytest.fixture
def robot_file(kind):
    return ROBOTS[kind]
