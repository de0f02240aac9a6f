"""The programs the bounded resolvers solve (Resolution.program) and check_resolver's KKT check of them.

* program_residuals against a QP and an LP solved by hand: the four KKT residuals vanish at the optimum with
  its multipliers, and each rises on its own when the point or a multiplier is wrong;
* every registered resolver that solves a program records it, with the torques of its plain step bit for bit,
  and meets the check on planar3 and panda, with and without joint limits;
* check_resolver fails on bounded resolvers broken on purpose: a solution moved off the optimum, a torque that
  is not the program's, the null-space term's sign flipped in the program, multipliers of the wrong sign, an
  option ignored.
"""

import copy

import numpy as np
import pytest

import torqueopt
from torqueopt.resolvers import BoundedTorque, MinMaxTorque, Program, Resolver
from torqueopt.resolvers.base import _defining_class
from torqueopt.testing import PROGRAM_TOLERANCE, ContractViolation, check_resolver, program_residuals

#: The registered resolvers that solve a program at each step (those with a program_solver of their own).
PROGRAM_RESOLVERS = ["bounded-torque", "minmax-torque", "energy-bounded-torque"]

#: check_resolver's options per resolver, as tests/test_resolvers.py gives them (options that act only in
#: situations random states do not reach are left out).
CONTRACT_OPTIONS = {
    "bounded-torque": {"joint_acceleration_limit": 0.5, "infeasible": None, "joint_limits": None},
    "minmax-torque": {"joint_acceleration_limit": 0.5, "infeasible": None, "joint_limits": None},
    "energy-bounded-torque": {"energy_limit": 1e-3, "energy_rate": None, "infeasible": None, "joint_limits": None,
                              "joint_acceleration_limit": None},
}  # fmt: skip


def clipped_qp(multipliers=None, solution=(0.5, 2.0)) -> Program:
    """min ½‖x − (1, 2)‖² s.t. x₀ <= 0.5 and −1 <= x₀ + x₁ <= 3: by hand, x = (0.5, 2) with only x₀ <= 0.5
    active (x₀ + x₁ = 2.5 inside), λ = (0.5, 0)."""
    return Program(
        hessian=np.eye(2),
        cost=np.array([-1.0, -2.0]),
        rows=np.array([[1.0, 0.0], [1.0, 1.0]]),
        lower=np.array([-np.inf, -1.0]),
        upper=np.array([0.5, 3.0]),
        solution=np.array(solution),
        multipliers=None if multipliers is None else np.array(multipliers),
        torque_offset=np.zeros(2),
        torque_rows=np.eye(2),
    )


def test_program_residuals_vanish_at_a_qp_optimum_solved_by_hand():
    for multipliers in ((0.5, 0.0), None):  # given, and fitted by nnls on the active side
        residuals = program_residuals(clipped_qp(), None if multipliers is None else np.array(multipliers))
        assert residuals[:4] == (0.0, 0.0, 0.0, 0.0)
        np.testing.assert_allclose(residuals.multipliers, [0.5, 0.0], atol=1e-15)


def test_each_kkt_residual_rises_on_its_own_break():
    # x₁ moved by 0.1: a free direction, so only stationarity breaks, by 0.1 of its terms' size (|x₁| + |q₁| = 4.1)
    moved = program_residuals(clipped_qp([0.5, 0.0], solution=(0.5, 2.1)))
    assert moved.stationarity == pytest.approx(0.1 / 4.1) and moved[1:4] == (0.0, 0.0, 0.0)
    # beyond x₀ <= 0.5 by 0.1, relative to |a||x| + |u| = 0.6 + 0.5 (a side beyond its bound counts as active, so
    # the fitted multiplier 0.4 balances the gradient there: only primal feasibility fails)
    beyond = program_residuals(clipped_qp(solution=(0.6, 2.0)))
    assert beyond.primal == pytest.approx(0.1 / 1.1) and (beyond.stationarity, beyond.dual) == (0.0, 0.0)
    # a multiplier on the lower side of x₀ <= 0.5, which has none: dual feasibility (its term 0.5 against the
    # largest sum of the stationarity terms, |x₁| + |q₁| = 4), and stationarity
    wrong_side = program_residuals(clipped_qp(), np.array([-0.5, 0.0]))
    assert wrong_side.dual == pytest.approx(0.5 / 4) and wrong_side.stationarity == pytest.approx(1 / 4)
    # a multiplier 0.5 on x₀ + x₁ <= 3, whose slack is 0.5 (of |a||x| + |u| = 5.5): complementary slackness
    slack = program_residuals(clipped_qp(), np.array([0.5, 0.5]))
    assert slack.complementarity == pytest.approx(min(0.5 / 4.5, 0.5 / 5.5)) and slack.dual == 0.0


def test_program_residuals_of_an_lp_vertex_solved_by_hand():
    """max x₀ + x₁ (min −x₀ − x₁) over the box 0 <= x <= 1 written as rows: the vertex (1, 1), λ = (1, 1) on the
    upper sides; at (1, 0.5) no non-negative multipliers balance the cost."""
    lp = Program(np.zeros((2, 2)), -np.ones(2), np.eye(2), np.zeros(2), np.ones(2), np.ones(2), None, np.zeros(2),
                 np.eye(2))  # fmt: skip
    assert program_residuals(lp)[:4] == (0.0, 0.0, 0.0, 0.0)
    np.testing.assert_array_equal(program_residuals(lp).multipliers, [1.0, 1.0])
    assert program_residuals(lp._replace(solution=np.array([1.0, 0.5]))).stationarity == pytest.approx(1 / 2)


def test_every_registered_program_resolver_is_listed():
    """The registered torque resolvers with a program_solver of their own are the ones this file checks."""
    own = [
        name
        for name in torqueopt.resolver_names("torque")
        if _defining_class(torqueopt.resolvers.RESOLVERS[name], "program_solver") is not Resolver
    ]
    assert own == PROGRAM_RESOLVERS


@pytest.mark.parametrize("joint_limits", ["on", "off"])
@pytest.mark.parametrize("name", PROGRAM_RESOLVERS)
def test_every_program_resolver_meets_the_kkt_check_on_planar3(name, joint_limits, planar3):
    """On planar3's own limits random states reach them: active bounds at the optimum and infeasible steps whose
    program is the optimum at the task acceleration achieved (or the min-max LP)."""
    resolver = torqueopt.get_resolver(name, **({} if joint_limits == "on" else {"joint_limits": "off"}))
    options = {**CONTRACT_OPTIONS[name], **({} if joint_limits == "on" else {"joint_acceleration_limit": None})}
    report = check_resolver(resolver, planar3, options=options)
    assert "program" in report.checks and not any(line.startswith("program") for line in report.unchecked)
    active = 0
    for q, v, task_acceleration in torqueopt.testing.contract_states(planar3):
        program = resolver.program_solver(planar3)(planar3.terms(q, v), task_acceleration).program
        if program is not None:
            active += np.count_nonzero(program_residuals(program).multipliers)
    assert active > 0  # the check saw multipliers at work, not only interior optima


@pytest.mark.parametrize("policy", ["least-error", "exceed"])
def test_the_programs_of_infeasible_steps_meet_the_kkt_check(policy, planar3):
    """Some of planar3's random states have no torque within its limits: the program recorded there is the
    optimum at the task acceleration achieved (least-error) or the min-max LP (exceed), and meets the check."""
    resolver = torqueopt.get_resolver("bounded-torque", infeasible=policy)
    assert "program" in check_resolver(resolver, planar3, options=CONTRACT_OPTIONS["bounded-torque"]).checks
    step = resolver.program_solver(planar3)
    resolutions = [step(planar3.terms(q, v), xdd) for q, v, xdd in torqueopt.testing.contract_states(planar3)]
    infeasible = [resolution.program for resolution in resolutions if resolution.infeasible]
    assert infeasible and all(program is not None for program in infeasible)
    variables = {program.variables.split(":")[0] for program in infeasible}
    assert variables == ({"(z, t)"} if policy == "exceed" else {"y"})


@pytest.mark.parametrize("joint_limits", ["on", "off"])
@pytest.mark.parametrize("name", PROGRAM_RESOLVERS)
def test_every_program_resolver_meets_the_kkt_check_on_panda(name, joint_limits, panda):
    resolver = torqueopt.get_resolver(name, **({} if joint_limits == "on" else {"joint_limits": "off"}))
    options = {**CONTRACT_OPTIONS[name], **({} if joint_limits == "on" else {"joint_acceleration_limit": None})}
    assert "program" in check_resolver(resolver, panda, options=options).checks


def test_the_recorded_program_is_the_plain_steps_and_its_torque(planar3, panda):
    """Recording changes no number: the same torques bit for bit, warm starts and all, over a sequence of states."""
    for robot in (planar3, panda):
        states = torqueopt.testing.contract_states(robot, 6, seed=3)
        for name in PROGRAM_RESOLVERS:
            resolver = torqueopt.get_resolver(name)
            plain, recording = resolver.solver(robot), resolver.program_solver(robot)
            for q, v, task_acceleration in states:
                terms = robot.terms(q, v)
                expected, recorded = plain(terms, task_acceleration), recording(terms, task_acceleration)
                assert expected.program is None
                np.testing.assert_array_equal(recorded.torque, expected.torque)
                np.testing.assert_array_equal(recorded.joint_acceleration, expected.joint_acceleration)
                program = recorded.program
                if program is not None:
                    torque = program.torque_offset + program.torque_rows @ program.solution
                    np.testing.assert_allclose(torque, recorded.torque, rtol=0, atol=1e-9 * np.abs(torque).max())


# -- bounded resolvers broken on purpose -------------------------------------------------------------------------


class OffOptimum(BoundedTorque):
    """bounded-torque whose answer lies 1e-3 rad/s² off its QP's optimum in each null-space coordinate, its recorded
    solution moved alike (a consistent record of a wrong answer)."""

    def _optimum(self, robot, *arguments, **keywords):
        optimum = super()._optimum(robot, *arguments, **keywords)
        step = np.full(robot.redundancy, 1e-3)

        def moved(terms, basis, inertia_basis, tilde_torque, particular, joint_rows):
            found = optimum(terms, basis, inertia_basis, tilde_torque, particular, joint_rows)
            if found is None:
                return None
            y, torque, program = found
            if program is not None:
                program = program._replace(solution=program.solution + step)
            return y + step, torque + inertia_basis @ step, program

        return moved


class NotTheProgramsTorque(BoundedTorque):
    """bounded-torque whose torque moves 1e-3 rad/s² along the null space while its record keeps the QP's solution."""

    def _optimum(self, robot, *arguments, **keywords):
        optimum = super()._optimum(robot, *arguments, **keywords)
        step = np.full(robot.redundancy, 1e-3)

        def moved(terms, basis, inertia_basis, tilde_torque, particular, joint_rows):
            found = optimum(terms, basis, inertia_basis, tilde_torque, particular, joint_rows)
            return None if found is None else (found[0] + step, found[1] + inertia_basis @ step, found[2])

        return moved


class FlippedNullSpaceTerm(BoundedTorque):
    """bounded-torque whose QP has the sign of its null-space term flipped, μ̄²‖y − K_D Zᵀq̇‖²: the self-motion
    is driven on, not damped. DAQP solves that QP exactly, so its own KKT conditions hold."""

    def _optimum(self, robot, *arguments, **keywords):
        flipped = copy.copy(self)
        flipped.damping = -self.damping
        return BoundedTorque._optimum(flipped, robot, *arguments, **keywords)


class WrongSignMultipliers(MinMaxTorque):
    """minmax-torque whose recorded multipliers have their signs flipped (its answer is right)."""

    def _optimum(self, robot, *arguments, **keywords):
        optimum = super()._optimum(robot, *arguments, **keywords)

        def flipped(*state):
            found = optimum(*state)
            if found is None or found[2] is None:
                return found
            return found[0], found[1], found[2]._replace(multipliers=-found[2].multipliers)

        return flipped


class IgnoredKinematicWeight(BoundedTorque):
    """bounded-torque whose programs always take μ = 0.5, whatever its kinematic_weight option says (its feasible
    QP and the infeasible steps' programs alike: the contract's states include steps on the joint bounds)."""

    def _fixed(self):
        fixed = copy.copy(self)
        fixed.kinematic_weight = 0.5
        return fixed

    def solver(self, robot):
        return BoundedTorque.solver(self._fixed(), robot)

    def program_solver(self, robot):
        return BoundedTorque.program_solver(self._fixed(), robot)


def failed_checks(resolver, robot) -> list[str]:
    """The lines of check_resolver's ContractViolation on ``resolver`` (it must raise)."""
    with pytest.raises(ContractViolation) as failure:
        check_resolver(resolver, robot, options=CONTRACT_OPTIONS[resolver.name])
    return str(failure.value).splitlines()[1:]


def test_check_resolver_fails_on_a_solution_off_the_optimum(planar3):
    lines = failed_checks(OffOptimum(), planar3)
    assert {line.split(":")[0] for line in lines} == {"program", "objective"}
    program_lines = [line for line in lines if line.startswith("program")]
    assert any("KKT stationarity residual" in line for line in program_lines)
    assert all("KKT" in line for line in program_lines)  # the torque is its solution's: only optimality fails


def test_check_resolver_fails_on_a_torque_that_is_not_its_programs(planar3):
    lines = failed_checks(NotTheProgramsTorque(), planar3)
    assert {line.split(":")[0] for line in lines} == {"program", "objective"}
    assert all(
        ", the step returns [" in line for line in lines if line.startswith("program")
    )  # its QP's own solution is optimal: only the tie to the torque fails


def test_check_resolver_fails_on_a_flipped_sign_in_the_null_space_term(planar3, panda):
    """The program is wrong but solved right: its own KKT conditions hold, and the declared criterion's, under the
    program's constraints, do not."""
    for robot in (planar3, panda):
        lines = failed_checks(FlippedNullSpaceTerm(), robot)
        assert lines and all(line.startswith("objective: state ") for line in lines)
        assert "the minimum of its criterion under its program's constraints lies" in lines[0]


def test_check_resolver_fails_on_multipliers_of_the_wrong_sign(planar3):
    lines = failed_checks(WrongSignMultipliers(), planar3)
    assert lines and all(line.startswith("program: state ") for line in lines)
    assert all(
        line.endswith(f"with its solver's multipliers (tolerance {PROGRAM_TOLERANCE:g}, relative)") for line in lines
    )
    assert any("KKT dual feasibility" in line for line in lines)


def test_check_resolver_fails_on_an_ignored_option_of_a_program_resolver(planar3):
    assert failed_checks(IgnoredKinematicWeight(), planar3) == [
        "options: kinematic_weight=1 changed no torque at 6 states (from 0.5): the step ignores it"
    ]
