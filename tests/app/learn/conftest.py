"""Shared by the learning tests: models fitted on one BLAS thread, as the fit itself fits them,
and one simulated head process per module for the tests that babble it through ``facesynth
learn`` as processes."""

from __future__ import annotations

from collections.abc import Iterator

import pytest
from facesynth_processes import simhead_device
from threadpoolctl import threadpool_limits


@pytest.fixture(autouse=True)
def _one_blas_thread() -> Iterator[None]:
    """Each test on one BLAS thread, as :func:`facesynth.app.learn.fit.fit_learned_profile`
    fits: the tests that fit a model family or a regional model directly (``fit_model``,
    ``fit_parts``) otherwise ran it on every core, which on small matrices only fights over
    them (an MLP's parts 9.4 s against 0.43 s on one thread, measured on the loaded two-core
    machine)."""
    with threadpool_limits(limits=1):
        yield


@pytest.fixture(scope="module")
def simhead(tmp_path_factory: pytest.TempPathFactory) -> Iterator[tuple[str, str]]:
    """One simulated head (simhead16) for a module's tests: its Maestro's serial link and its
    camera's URL. Each ``facesynth learn`` run starts by sending it to neutral and ends there
    (a run stopped with Ctrl-C too), so no test sees another's pose; its start-up (the
    renderer's face, the camera) is paid once a module."""
    with simhead_device(tmp_path_factory.mktemp("simhead")) as device:
        yield device
