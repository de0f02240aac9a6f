"""The kinetic-energy stack's own energies (``StackedKineticEnergyPseudoInverse.energies``), which the batch's energy
extras take instead of ``self_motion_energy``: T and E_N from the pass's H and the G⁻¹ its rates computed must equal
the shared function's (H by the robot's own CRBA, H⁻¹Jᵀ and Λ by LAPACK) to round-off, state by state and run by run.
"""

import numpy as np
import pinocchio as pin
import pytest

import torqueopt
from torqueopt.atlas import PopulationSpec, draw_population
from torqueopt.batch import simulate_batch
from torqueopt.robot_copies import RobotForest
from torqueopt.self_motion import self_motion_energy
from torqueopt.terms import PinocchioTerms


def _robot(name, planar3, panda):
    return {"planar3": planar3, "panda": panda}[name]


def _crba(robot, q):
    """H per row by the robot's own CRBA (made whole from its upper triangle)."""
    data = robot.model.createData()
    inertia = np.empty((len(q), robot.nv, robot.nv))
    for row, configuration in enumerate(q):
        upper = pin.crba(robot.model, data, configuration)
        inertia[row] = np.triu(upper) + np.triu(upper, 1).T
    return inertia


@pytest.mark.parametrize("name", ["planar3", "panda"])
def test_the_stacks_energies_are_self_motion_energys(name, planar3, panda):
    """Random states through a forest of 5 copies: T and E_N of the stack's own rates (E_N zero but for round-off)
    and of random joint velocities (E_N of the order of T) against ``self_motion_energy`` at 1e-12 of T."""
    robot = _robot(name, planar3, panda)
    rng = np.random.default_rng(4)
    count = 23
    low = np.maximum(robot.model.lowerPositionLimit, -3.0)
    high = np.minimum(robot.model.upperPositionLimit, 3.0)
    q = rng.uniform(low, high, (count, robot.nv))
    stack = torqueopt.get_resolver("kinetic-energy-pinv").stack_rate_function(robot)
    found = RobotForest(robot, copies=5).kinematics(q, inertia=True)
    jacobian = found.jacobian[:, robot.task_rows]
    rates, _, failures, state = stack.rates(jacobian, rng.normal(size=(count, robot.m)), q, found)
    assert not failures
    inertia = _crba(robot, q)
    random_velocities = rng.normal(size=(count, robot.nv))
    for velocity in (rates, random_velocities):
        kinetic, self_motion = stack.energies(jacobian, velocity, state, found)
        expected_kinetic, expected_self_motion = self_motion_energy(inertia, velocity, jacobian=jacobian)
        scale = 1.0 + expected_kinetic
        assert np.all(np.abs(kinetic - expected_kinetic) <= 1e-12 * scale)
        assert np.all(np.abs(self_motion - expected_self_motion) <= 1e-12 * scale)
    assert np.median(self_motion / kinetic) > 0.1  # the random velocities move the null space


@pytest.mark.parametrize("name", ["planar3", "panda"])
def test_the_batchs_energy_extras_are_self_motion_energys_at_the_recorded_states(name, planar3, panda):
    """The batch's extras (from the stack's own energies) against ``self_motion_energy`` at each run's recorded
    states, with H and J from ``simulate``'s own terms."""
    robot = _robot(name, planar3, panda)
    movements = draw_population(robot, PopulationSpec(paths=6, durations=(0.3,), seed=3))
    lines = [torqueopt.StraightLine(m.direction, duration=0.3, start=m.start) for m in movements]
    runs, extras = simulate_batch(robot, "kinetic-energy-pinv", lines, [m.q0 for m in movements], extras=True)
    provider = PinocchioTerms(robot)
    for run, extra in zip(runs, extras):
        terms, _ = provider.terms(run.q, run.v)
        kinetic, self_motion = self_motion_energy(terms.inertia, run.v, jacobian=terms.jacobian)
        assert len(extra.kinetic_energy) == len(run.t)
        assert kinetic.max() > 1e-3
        scale = 1.0 + kinetic
        assert np.all(np.abs(extra.kinetic_energy - kinetic) <= 1e-12 * scale)
        assert np.all(np.abs(extra.self_motion_energy - self_motion) <= 1e-12 * scale)
