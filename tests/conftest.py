import os

import numpy as np
import pytest

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
DATA = os.path.join(ROOT, "tests", "data")


@pytest.fixture
def data_dir():
    return DATA


@pytest.fixture
def rng():
    return np.random.default_rng(12345)
