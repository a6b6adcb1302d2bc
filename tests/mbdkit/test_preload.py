"""What a grading sandbox's zygote imports before it forks the children (``mbdkit._zygote.LEVELS``): scipy's
integrators only for checks that integrate (``mbdkit.runner.preload_for``)."""

from __future__ import annotations

from mbdkit import _zygote
from mbdkit.homework import load_homework
from mbdkit.probes import PROBES, REQUIRES
from mbdkit.runner import INTEGRATING, preload_for


def test_only_a_homework_that_integrates_preloads_the_integrators():
    assert preload_for(load_homework("hw1").checks) == "kinematic"  # kinematic analysis only
    assert preload_for(load_homework("hw2").checks) == "all"
    assert preload_for(load_homework("hw3").checks) == "all"
    hw2 = load_homework("hw2")
    integrating = [c for c in hw2.checks if c.probe == "dynamic_run"]
    assert integrating and preload_for(integrating) == "all"
    assert preload_for([c for c in hw2.checks if c.probe == "mass_matrix"]) == "kinematic"


def test_the_probes_that_integrate_are_those_that_run_the_integrators():
    integrating = {name for name in PROBES if INTEGRATING & set(REQUIRES[name])}
    assert "dynamic_run" in integrating
    assert not {"kinematic_run", "newton", "mass_matrix", "constraints"} & integrating


def test_the_kinematic_level_leaves_out_the_integrators_only():
    levels = _zygote.LEVELS
    assert levels["all"] == _zygote.PRELOAD and levels["bare"] == ()
    assert set(levels["all"]) - set(levels["kinematic"]) == set(_zygote.INTEGRATION)
    assert {"numpy", "scipy.linalg", "yaml", "jsonschema"} <= set(levels["kinematic"])
