"""Fair diagnosis: the known mistakes are named (phi' for phi'^2, one Baumgarte term's sign, B^T in the
velocities d_ij', lambda's opposite sign as the course's sign convention), and a likely cause never blames a
function whose own checks pass.

Each mutant (conftest's MUTANTS) is graded on the public checks of the scenes and probes its mistake reaches,
so the class is small; the expected causes follow from the mutation, not from the grader's output.
"""

from __future__ import annotations

import copy
import re

import pytest

from autograder.grading import run_checks
from mbdkit import diagnosis
from mbdkit.checks import Outcome, reconcile_causes
from mbdkit.homework import CheckSpec, load_homework
from mbdkit.scenes import PUBLIC

CASES = {
    "phi_not_squared": ("hw1", ("slider_crank.", "four_bar.gamma")),
    "velocity_b_transposed": ("hw1", ("drivers.", "sliding_arm.")),
    "baumgarte_damping_sign": ("hw2", ("double_pendulum.baumgarte", "double_pendulum.accelerations")),
    "lambda_sign": ("hw2", ("double_pendulum.augmented", "double_pendulum.accelerations", "slider_crank.inverse")),
}
"""mutant -> (homework, prefixes of the public checks it is graded on)."""


def _checks(homework: str, prefixes: tuple[str, ...]) -> list[CheckSpec]:
    return [c for c in load_homework(homework).checks if c.kind == PUBLIC and c.name.startswith(prefixes)]


@pytest.fixture(scope="module")
def graded(make_submissions) -> dict[str, tuple[list[CheckSpec], dict[str, Outcome]]]:
    found = {}
    for mutant, (homework, prefixes) in CASES.items():
        folder = make_submissions(mutant, {"ada": mutant}, homework) / "ada"
        checks = _checks(homework, prefixes)
        outcomes = run_checks(checks, folder, homework, "ada", budget=600)
        found[mutant] = checks, {o.name: o for o in outcomes}
    return found


def _cause(message: str) -> list[str]:
    return re.findall(r"Likely cause: (.*?)(?:; (?=[A-Za-z' ]+: )|$)", message)


def test_phi_for_phi_squared_is_named(graded):
    _, outcomes = graded["phi_not_squared"]
    for name in ("slider_crank.gamma.revolute", "four_bar.gamma.revolute", "slider_crank.acceleration"):
        assert "phi' where phi'^2 belongs" in outcomes[name].message, outcomes[name].message
    for name in ("slider_crank.constraints.revolute", "slider_crank.jacobian.revolute", "slider_crank.velocity"):
        assert outcomes[name].passed, outcomes[name].message


def test_b_transposed_in_the_velocities_is_named_and_the_jacobian_is_not_blamed(graded):
    _, outcomes = graded["velocity_b_transposed"]
    assert outcomes["drivers.jacobian.revolute_revolute"].passed
    message = outcomes["drivers.gamma.revolute_revolute"].message
    assert "B(phi)^T in d_ij'" in message and "used where B(phi)" not in message
    assert "B(phi)^T in d_ij'" in outcomes["sliding_arm.gamma.prismatic"].message


def test_one_baumgarte_term_with_the_wrong_sign_is_named(graded):
    _, outcomes = graded["baumgarte_damping_sign"]
    for name in ("double_pendulum.baumgarte_gamma", "double_pendulum.accelerations"):
        assert "one Baumgarte term with the wrong sign: + 2 alpha Psi'" in outcomes[name].message


def test_lambdas_opposite_sign_is_the_sign_convention_and_costs_only_the_lambda_checks(graded):
    checks, outcomes = graded["lambda_sign"]
    for name in ("double_pendulum.augmented_accelerations", "double_pendulum.accelerations"):
        message = outcomes[name].message
        assert not outcomes[name].passed and diagnosis.LAMBDA_SIGN in message
        assert "M q'' + Psi_q^T lambda = Q" in message.split("Likely cause")[0]  # the convention where it is checked
        assert "a sign error" not in message
        assert "q'' of" not in message and "accelerations q''" not in message  # q'' itself is right
    assert outcomes["slider_crank.inverse_dynamics"].passed  # not the mutated function


@pytest.mark.parametrize("mutant", sorted(CASES))
def test_no_cause_blames_a_function_whose_checks_pass(graded, mutant):
    checks, outcomes = graded[mutant]
    specs = {c.name: c for c in checks}
    for outcome in outcomes.values():
        for cause in _cause(outcome.message):
            found = diagnosis.blamed(cause)
            if found is None:
                continue
            own = [o for o in outcomes.values() if specs[o.name].probe in found[0]]
            assert not own or not all(o.passed for o in own), (outcome.name, cause)


def test_a_cause_whose_function_passes_is_replaced_by_the_next_that_fits(graded):
    """The B^T mutant's distance gamma is also explained by B^T in the Jacobian; named first, that cause would
    blame Psi_q, whose checks pass: it is taken back and the velocities' cause named instead."""
    checks, outcomes = graded["velocity_b_transposed"]
    outcome = copy.deepcopy(outcomes["drivers.gamma.revolute_revolute"])
    right, wrong = outcome.causes[0][0], "a transposed block: B(phi)^T used where B(phi) = dA/dphi belongs (eq. 2.5)"
    assert wrong in outcome.causes[0]  # the numbers fit both
    outcome.message = outcome.message.replace(right, wrong)
    alone = copy.deepcopy(outcome)
    outcome.causes, alone.causes = [[wrong, right]], [[wrong]]
    others = [o for o in outcomes.values() if o.name != outcome.name]
    fixed = {o.name: o for o in reconcile_causes(checks, [*others, outcome])}
    assert right in fixed[outcome.name].message and wrong not in fixed[outcome.name].message
    taken = reconcile_causes(checks, [*others, alone])[-1]
    assert "Likely cause" not in taken.message and taken.message.startswith("drivers:")
