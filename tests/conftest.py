"""Fixtures shared by every test folder: the data folder, a seeded generator, and synthetic
scenes, models and scan files built once per session."""
import functools

import numpy as np
import pytest

from engine.grammar import reconstruct_manhattan
from engine.grammar.generic import reconstruct_generic
from engine.io import write_ply
from engine.synthetic import preset
from scenes import DATA


@pytest.fixture
def data_dir():
    return DATA


@pytest.fixture
def rng():
    return np.random.default_rng(12345)


# ------------------------------------------------------------ shared scenes and models
# Simulated scans and their reconstructions that several test files use are built once per
# session, keyed by everything that makes them (preset, seed, noise, point count; method and
# seed of the reconstruction). Tests must treat what they get as read-only.

@functools.lru_cache(maxsize=None)
def _scene(name: str, seed: int, noise, points: int):
    return preset(name, seed=seed, noise=noise, target_points=points)


@functools.lru_cache(maxsize=None)
def _model(method: str, name: str, seed: int, noise, points: int, rng: int = 0):
    cloud = _scene(name, seed, noise, points).cloud
    if method == "manhattan":
        return reconstruct_manhattan(cloud, rng=rng)
    if method == "generic":
        return reconstruct_generic(cloud, rng=rng)
    raise ValueError(f"unknown method {method!r}")


@pytest.fixture(scope="session")
def synthetic_scene():
    """``synthetic_scene(name, seed, noise, points)``: the ``engine.synthetic`` preset scene,
    simulated once per test session."""
    return _scene


@pytest.fixture(scope="session")
def synthetic_model():
    """``synthetic_model(method, name, seed, noise, points, rng=0)``: the model
    ``reconstruct_manhattan`` / ``reconstruct_generic`` makes of that scene's cloud, once
    per test session."""
    return _model


@pytest.fixture(scope="session")
def synthetic_scan_file(tmp_path_factory):
    """``synthetic_scan_file(name, seed, points, filename)``: the path of that preset's TLS scan
    written once per session as a binary PLY called ``filename`` (its own folder per call)."""
    made = {}

    def get(name: str, seed: int, points: int, filename: str):
        key = (name, seed, points, filename)
        if key not in made:
            path = tmp_path_factory.mktemp("scan") / filename
            write_ply(path, _scene(name, seed, "tls", points).cloud)
            made[key] = path
        return made[key]

    return get
