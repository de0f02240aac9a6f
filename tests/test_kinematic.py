"""The velocity-level methods of Section 1.1: each equation against an independent computation,
and the known results on the paper's arm (repeatability, joint limits, manipulability, priority,
obstacle clearance)."""

import re
import sys

import numpy as np
import pinocchio as pin
import pytest

import torqueopt
from torqueopt.cli import main
from torqueopt.errors import InvalidInput, NoRedundancy, SingularJacobian
from torqueopt.kinematic import joint_rates
from torqueopt.resolvers.velocity import JointLimits, manipulability
from torqueopt.resolvers.velocity.obstacle_avoidance import activation
from torqueopt.resolvers.velocity.pseudoinverse import inverse_inertia_at
from torqueopt.tasks import FrameTask, Kinematics, ObstacleTask, PostureTask, prioritised_rates
from torqueopt.whiplash import detect_whiplash

from .conftest import PAPER_Q0
from .test_tasks import central, planar_jacobian, planar_points
from .velocity_oracles import stacked_steps

LONG = torqueopt.StraightLine((1.0, 1.0), duration=2.0)
#: A circle the paper's arm can go round from q0 on both branches (centre along +x of the start).
LOOP = torqueopt.Circle(0.5, 4.0, centre_direction=[1.0, 0.0])
ELBOW_TARGET = [0.5, -0.5]
OBSTACLE = [1.2, 0.3, 0.0, 0.1]


def closed_form_manipulability(q):
    jacobian = planar_jacobian(q)
    return np.sqrt(np.linalg.det(jacobian.dot(jacobian.T)))  # Eq. (6)


def closed_form_joint_limits(q, lower, upper):
    middle = 0.5 * (lower + upper)
    return np.sum(((q - middle) / (middle - upper)) ** 2)  # Eq. (5)


# -- each equation at single states ---------------------------------------------------------


def test_velocity_pinv_is_eq_2_and_3_with_the_closed_form_jacobian(planar3, rng):
    for _ in range(5):
        q, xdot, phi = rng.uniform(-2, 2, 3), rng.normal(size=2), rng.normal(size=3)
        jacobian = planar_jacobian(q)
        pinv = jacobian.T.dot(np.linalg.inv(jacobian.dot(jacobian.T)))  # Eq. (3)
        np.testing.assert_allclose(joint_rates(planar3, "velocity-pinv", q, xdot), pinv.dot(xdot), atol=1e-12)
        with_self_motion = torqueopt.get_resolver("velocity-pinv", self_motion=phi)
        expected = pinv.dot(xdot) + (np.eye(3) - pinv.dot(jacobian)).dot(phi)  # Eq. (2)
        np.testing.assert_allclose(joint_rates(planar3, with_self_motion, q, xdot), expected, atol=1e-12)


def _closed_form_is_the_rate_derivative(robot, resolver, rng, accept=None, states=5, tolerance=1e-9):
    """The resolver's closed-form q̈ at random states against a five-point difference of its rates along
    q(s) = q + s q̇, c(s) = c + s ċ (error ~1e-11), at ``tolerance`` of the largest q̈ (at least 1);
    ``accept(kinematics, task)`` skips the states where the method itself is near a singularity of its own."""
    task, kinematics = FrameTask.of_robot(robot), Kinematics(robot)
    rates = resolver.rate_function(robot, task)
    closed_form = resolver.acceleration_function(robot, task)
    assert closed_form is not None
    tested = 0
    while tested < states:
        q = pin.randomConfiguration(robot.model) if robot.nv > 3 else rng.uniform(-2, 2, 3)
        command, command_rate = rng.normal(size=robot.m), rng.normal(size=robot.m)
        try:
            velocity, inverse_condition = rates(kinematics.update(q), command)
        except SingularJacobian:
            continue  # the method is undefined there (an algorithmic singularity of the extended Jacobian)
        if inverse_condition < 0.1 or (accept is not None and not accept(kinematics, task)):
            continue  # near a singularity the difference's own error grows past the tolerance
        tested += 1

        def along(s, q=q, velocity=velocity, command=command, command_rate=command_rate):
            return rates(kinematics.update(q + s * velocity), command + s * command_rate)[0]

        h = 1e-4
        expected = (8 * (along(h) - along(-h)) - (along(2 * h) - along(-2 * h))) / (12 * h)
        got = closed_form(kinematics.update(q), velocity, command, command_rate)
        np.testing.assert_allclose(got, expected, rtol=0, atol=tolerance * max(1.0, np.abs(expected).max()))


@pytest.mark.parametrize(
    "name, options",
    [
        ("velocity-pinv", {}),
        ("gradient-projection", {}),
        ("gradient-projection", {"k": 40.0}),
        ("gradient-projection", {"criterion": "manipulability", "k": 5.0}),
        ("kinetic-energy-pinv", {}),
        ("task-priority", {}),
    ],
)
def test_the_closed_form_joint_acceleration_is_the_time_derivative_of_the_rates(planar3, panda, rng, name, options):
    """q̈ = d/dt f(q, c(t)) against a five-point difference along the motion: velocity-pinv's J⁺c, gradient
    projection's J⁺c − k(I − J⁺J)∂p/∂q (Eq. (4): joint limits, Eq. (5), and −w, Eq. (6)), the kinetic-energy
    pseudoinverse H⁻¹Jᵀ(JH⁻¹Jᵀ)⁻¹c (Eq. (16), Ḣ from Pinocchio's Coriolis matrix) and task priority, Eq. (11),
    with its default posture task."""
    pin.seed(int(rng.integers(2**31)))
    for robot in (planar3, panda):
        _closed_form_is_the_rate_derivative(robot, torqueopt.get_resolver(name, **options), rng)


def _secondary_well_conditioned(secondary):
    """States where each secondary frame task, projected into the null space of the robot's task, keeps its
    smallest nonzero singular value above 0.2 (the five-point difference loses digits as q̈ grows near 0)."""

    def accept(kinematics, task):
        jacobian = task.jacobian(kinematics)
        projector = np.eye(jacobian.shape[1]) - np.linalg.pinv(jacobian).dot(jacobian)
        for lower in secondary:
            singular = np.linalg.svd(lower.jacobian(kinematics).dot(projector), compute_uv=False)
            if singular[singular > 1e-8].min() < 0.2:
                return False
        return True

    return accept


def test_task_priority_closed_form_with_frame_tasks_is_the_time_derivative_of_eq_11(planar3, panda, rng):
    """As above, with secondary frame tasks: the elbow of the paper's arm (J_l(I − J⁺J) of rank 1, so the
    derivative of a rank-deficient pseudoinverse), and panda's fourth link above a posture task (three levels)."""
    pin.seed(int(rng.integers(2**31)))
    elbow = FrameTask("link3", "xy", target=ELBOW_TARGET, gain=2.0)
    link4 = FrameTask("panda_link4", "position", target=[0.3, 0.0, 0.6])
    for robot, secondary in ((planar3, [elbow]), (panda, [link4, PostureTask(gain=3.0)])):
        resolver = torqueopt.get_resolver("task-priority", secondary=secondary)
        resolver.check(robot)
        _closed_form_is_the_rate_derivative(robot, resolver, rng, accept=_secondary_well_conditioned(secondary[:1]))


@pytest.mark.parametrize("n, rows, lower_rows", [(3, 2, 2), (7, 3, 3), (7, 3, 6), (6, 2, 1)])
def test_task_priority_below_one_task_is_the_readable_recursion(rng, n, rows, lower_rows):
    """The q̈ of Eq. (11) below one task in fewer products against prioritised_accelerations, its reference: the
    lower level rank-deficient once projected (2 rows in 1 freedom, 6 in 4) and of full rank."""
    from torqueopt.resolvers.velocity.task_priority import accelerations_below_one_task
    from torqueopt.tasks import prioritised_accelerations, priority_levels

    for _ in range(10):
        jacobians = [rng.normal(size=(rows, n)), rng.normal(size=(lower_rows, n))]
        jacobian_rates = [rng.normal(size=(rows, n)), rng.normal(size=(lower_rows, n))]
        velocities = [rng.normal(size=rows), rng.normal(size=lower_rows)]
        velocity_rates = [rng.normal(size=rows), rng.normal(size=lower_rows)]
        levels, _ = priority_levels(jacobians, final_projector=False)
        expected = prioritised_accelerations(jacobians, jacobian_rates, velocities, velocity_rates, levels=levels)[1]
        got = accelerations_below_one_task(
            levels, *jacobian_rates, velocities[0], velocity_rates[0], velocities[1], velocity_rates[1]
        )
        np.testing.assert_allclose(got, expected, rtol=0, atol=1e-12 * np.abs(expected).max())


def test_task_priority_below_one_task_rates_are_those_of_the_recursion(planar3, panda, rng):
    """Below one frame task without damping, the rates of Eq. (11) from the levels built at each configuration
    (the lower SVD in one object for the run, below_one_task_steps) against rates_through the levels
    priority_levels gives: bit for bit."""
    from torqueopt.linalg import JacobianSolver
    from torqueopt.resolvers.velocity.task_priority import below_one_task_steps
    from torqueopt.tasks import priority_levels, rates_through

    pin.seed(int(rng.integers(2**31)))  # randomConfiguration's generator is Pinocchio's global one
    elbow = FrameTask("link3", "xy", target=ELBOW_TARGET, gain=2.0)
    link4 = FrameTask("panda_link4", "position", target=[0.3, 0.0, 0.6])
    for robot, lower in ((planar3, elbow), (panda, link4)):
        resolver = torqueopt.get_resolver("task-priority", secondary=lower)
        task = FrameTask.of_robot(robot)
        rates, _ = below_one_task_steps(robot, task, lower, resolver.singular_tolerance)
        for _ in range(3):
            kinematics = Kinematics(robot).update(pin.randomConfiguration(robot.model))
            command = rng.normal(size=robot.m)
            jacobian = task.jacobian(kinematics)
            inverse, _ = JacobianSolver(robot.m, robot.nv, null_space=False).pseudoinverse(jacobian)
            levels, _ = priority_levels([jacobian, lower.jacobian(kinematics)], first_inverse=inverse)
            expected = rates_through(levels, [command, lower.desired_velocity(kinematics)])
            np.testing.assert_array_equal(rates(kinematics, command)[0], expected)


def test_the_extended_jacobian_closed_form_is_the_time_derivative_of_eq_15(planar3, rng):
    """J_ex q̈ = [ċ − J̇q̇; −q̇ᵀ∇²Gq̇] (its curvature by a difference of the Eq. (15) row) against a five-point
    difference of the rates, at states whose alignment |∂G/∂q·n|/(|∂G/∂q| |n|) is 0.2 or more."""
    resolver = torqueopt.get_resolver("extended-jacobian")
    _closed_form_is_the_rate_derivative(
        planar3, resolver, rng, accept=lambda kinematics, task: resolver.alignment(kinematics, task) >= 0.2, states=10
    )


def _obstacle_away_from_kinks(obstacle, smallest, margin=0.05):
    """States where the closest point stays on its segment, inside it or at its end, over the five-point
    difference (the rates have a kink where it changes segment or reaches an end), and where
    J_o(I − J⁺J) keeps its smallest nonzero singular value above ``smallest``."""

    def accept(kinematics, task):
        model, data = kinematics.model, kinematics.data
        frame_id = model.getFrameId(kinematics.robot.frame)
        joints = [j for j in model.supports[model.frames[frame_id].parentJoint] if j > 0]
        origins = [data.oMi[joint].translation.copy() for joint in joints] + [data.oMf[frame_id].translation.copy()]
        segments = []  # (distance, fraction along the segment before the clip) of each segment
        for start, end in zip(origins[:-1], origins[1:]):
            axis = end - start
            length_squared = axis.dot(axis)
            fraction = 0.0 if length_squared == 0.0 else (obstacle.center - start).dot(axis) / length_squared
            segments.append((np.linalg.norm(start + min(1.0, max(0.0, fraction)) * axis - obstacle.center), fraction))
        (nearest, fraction), (second, _) = sorted(segments)[:2]
        if second - nearest < margin or min(abs(fraction), abs(fraction - 1.0)) < margin:
            return False
        jacobian = task.jacobian(kinematics)
        projector = np.eye(jacobian.shape[1]) - np.linalg.pinv(jacobian).dot(jacobian)
        point_jacobian = obstacle.point_jacobian(kinematics, obstacle.closest_point(kinematics))
        singular = np.linalg.svd(point_jacobian.dot(projector), compute_uv=False)
        return singular[0] > 1e-8 and singular[singular > 1e-8].min() >= smallest

    return accept


@pytest.mark.parametrize("influence, critical", [(3.0, 0.0), (10.0, 5.0)], ids=["activating", "active"])
def test_obstacle_avoidance_closed_form_is_the_time_derivative_of_eq_13(planar3, rng, influence, critical):
    """q̈ of Eq. (13) (with α_h's rate where the clearance is within (critical, influence), and at α_h = 1)
    against a five-point difference of the rates, obstacles anywhere near the arm, where the closest point
    moves smoothly (:func:`_obstacle_away_from_kinks`). On panda random obstacles are nearest to a joint (a kink)
    or J_o(I − J⁺J) is ill-conditioned at nearly every state: its runs below hold it to the loop's difference."""
    for _ in range(3):
        obstacle = ObstacleTask(rng.uniform(-1.0, 1.0, 3), 0.05, speed=0.4)
        resolver = torqueopt.get_resolver(
            "obstacle-avoidance", obstacle=obstacle, influence=influence, critical=critical
        )
        accept = _obstacle_away_from_kinks(obstacle, smallest=0.2)
        _closed_form_is_the_rate_derivative(planar3, resolver, rng, accept=accept, states=3)


@pytest.mark.parametrize("gain", [0.0, 5.0])
def test_obstacle_avoidance_runs_with_the_closed_form_equal_those_with_the_central_difference(planar3, panda, gain):
    """As for velocity-pinv above, for Eq. (13): the paper's movement past the obstacle of the CLI's example (the
    closest point passes from the last link to the middle one at about 1.48 s), and a panda line. At 3e-8: the
    difference's own round-off on planar3 is of the order of 1e-8 here (two units in the last place of q0 moved
    its torques by 1.4e-8, benchmarks/velocity_runs_unchanged.py); measured, τ 8.4e-9 (K = 0) and 9.4e-9 (K = 5)
    at steps 650-850, away from the change of segment, and q̈ 4.6e-9 and 3.4e-9."""
    from torqueopt.resolvers.velocity.obstacle_avoidance import ObstacleAvoidance

    options = {"planar3": {"obstacle": OBSTACLE}, "panda": {"obstacle": [0.4, 0.2, 0.5, 0.05]}}
    _closed_form_runs_equal_the_differenced_ones(
        planar3, panda, "obstacle-avoidance", ObstacleAvoidance, gain, options, tolerance=3e-8
    )


@pytest.mark.parametrize("gain", [0.0, 5.0])
def test_extended_jacobian_runs_with_the_closed_form_equal_those_with_the_central_difference(planar3, gain):
    """As for velocity-pinv above, on the paper's movement (the method needs n − m = 1: planar3 alone)."""
    from torqueopt.resolvers.velocity.extended_jacobian import ExtendedJacobian

    _closed_form_runs_equal_the_differenced_ones(planar3, None, "extended-jacobian", ExtendedJacobian, gain)


def test_task_priority_has_no_closed_form_where_it_does_not_hold(planar3):
    """Damping, an obstacle task or a pose task below: the loop's central difference (None)."""
    task = FrameTask.of_robot(planar3)
    for options in (
        {"damping": 0.1},
        {"secondary": ObstacleTask.from_spec(OBSTACLE)},
        {"secondary": FrameTask("link3", "pose")},
    ):
        assert torqueopt.get_resolver("task-priority", **options).acceleration_function(planar3, task) is None


def test_the_frame_jacobian_time_variation_is_the_derivative_of_the_jacobian_along_v(panda, rng):
    pin.seed(int(rng.integers(2**31)))
    kinematics, frame = Kinematics(panda), panda.frame_id
    for _ in range(3):
        q, v = pin.randomConfiguration(panda.model), rng.normal(size=panda.nv)
        got = kinematics.update(q).frame_jacobian_time_variation(frame, v).copy()
        h = 1e-6
        expected = (
            kinematics.update(q + h * v).frame_jacobian(frame) - kinematics.update(q - h * v).frame_jacobian(frame)
        ) / (2 * h)
        np.testing.assert_allclose(got, expected, rtol=0, atol=1e-8)


def _closed_form_runs_equal_the_differenced_ones(
    planar3, panda, name, resolver_class, gain, options=None, tolerance=1e-8
):
    """Runs of resolver ``name`` (closed-form q̈) against those of its class with the loop's central difference
    (``step_functions`` and ``acceleration_function`` giving no q̈), on the paper's movement and a panda line,
    at ``tolerance`` of q̈ and τ; ``options`` {robot name: resolver options} beside the position gain; ``panda``
    None for planar3 alone."""

    class Differenced(resolver_class):
        # The loop reads step_functions; the resolvers that share work between rates and q̈ build both there.
        def step_functions(self, robot, task):
            return super().step_functions(robot, task)[0], None

        def acceleration_function(self, robot, task):
            return None

    cases = [(planar3, PAPER_Q0, LONG)]
    if panda is not None:
        cases.append((panda, panda.default_configuration, torqueopt.StraightLine([1, 0, 0], 0.2, 1.0)))
    for robot, q0, line in cases:
        resolver_options = {"position_gain": gain, **(options or {}).get(robot.name, {})}
        closed = torqueopt.simulate(robot, name, line, q0, resolver_options=resolver_options)
        assert closed.completed
        assert torqueopt.get_resolver(name, **resolver_options).acceleration_function(robot, FrameTask.of_robot(robot))
        differenced = torqueopt.simulate(robot, Differenced(**resolver_options), line, q0)
        np.testing.assert_array_equal(closed.q, differenced.q)  # q̈ does not enter the motion
        scale = np.abs(differenced.acceleration).max()
        np.testing.assert_allclose(closed.acceleration, differenced.acceleration, rtol=0, atol=tolerance * scale)
        np.testing.assert_allclose(closed.tau, differenced.tau, rtol=0, atol=tolerance * np.abs(differenced.tau).max())


@pytest.mark.parametrize("gain", [0.0, 5.0])
def test_velocity_pinv_runs_with_the_closed_form_equal_those_with_the_central_difference(planar3, panda, gain):
    """The loop's reference q̈ (a central difference of f along q̇) against the closed form, run for run.

    The difference's own round-off is about ε|q̇|²/δ ≈ 1e-9 of q̈ (δ = 1e-6, measured up to 2e-9 with
    the position gain), hence 1e-8 here; the five-point test above holds the closed form at 1e-9.
    """
    from torqueopt.resolvers.velocity.pseudoinverse import VelocityPseudoInverse

    _closed_form_runs_equal_the_differenced_ones(planar3, panda, "velocity-pinv", VelocityPseudoInverse, gain)


@pytest.mark.parametrize("criterion, gain", [("joint-limits", 0.0), ("joint-limits", 5.0), ("manipulability", 5.0)])
def test_gradient_projection_runs_with_the_closed_form_equal_those_with_the_central_difference(
    planar3, panda, criterion, gain
):
    """As for velocity-pinv above: the closed-form q̈ of gradient projection (joint limits, and the manipulability
    with its curvature by a difference of its gradient) against the loop's central difference, run for run, on the
    paper's movement and a panda line."""
    from torqueopt.resolvers.velocity.gradient_projection import GradientProjection

    options = {robot: {"criterion": criterion} for robot in ("planar3", "panda")}
    _closed_form_runs_equal_the_differenced_ones(
        planar3, panda, "gradient-projection", GradientProjection, gain, options
    )


def test_gradient_projection_with_a_callable_criterion_keeps_the_loops_difference(planar3):
    """A callable's gradient is itself a difference: no closed form (None)."""
    resolver = torqueopt.get_resolver("gradient-projection", criterion=lambda angles: float(np.sum(angles**2)))
    assert resolver.acceleration_function(planar3, FrameTask.of_robot(planar3)) is None


@pytest.mark.parametrize("gain", [0.0, 5.0])
def test_kinetic_energy_pinv_runs_with_the_closed_form_equal_those_with_the_central_difference(planar3, panda, gain):
    """As for velocity-pinv above: the closed-form q̈ of the kinetic-energy pseudoinverse against the loop's
    central difference, run for run."""
    from torqueopt.resolvers.velocity.pseudoinverse import KineticEnergyPseudoInverse

    _closed_form_runs_equal_the_differenced_ones(
        planar3, panda, "kinetic-energy-pinv", KineticEnergyPseudoInverse, gain
    )


@pytest.mark.parametrize("secondary, gain", [("posture", 0.0), ("frame", 5.0)])
def test_task_priority_runs_with_the_closed_form_equal_those_with_the_central_difference(
    planar3, panda, gain, secondary
):
    """As for velocity-pinv above, for Eq. (11): the default posture task, and a frame task (the elbow of the
    paper's arm, panda's fourth link)."""
    from torqueopt.resolvers.velocity.task_priority import TaskPriority

    options = {}
    if secondary == "frame":
        options = {
            "planar3": {"secondary": FrameTask("link3", "xy", target=ELBOW_TARGET)},
            "panda": {"secondary": FrameTask("panda_link4", "position", target=[0.1, 0.1, 0.5])},
        }
    _closed_form_runs_equal_the_differenced_ones(planar3, panda, "task-priority", TaskPriority, gain, options)


def test_kinetic_energy_pinv_minimises_eq_17_by_the_kkt_conditions(planar3, panda, rng):
    pin.seed(int(rng.integers(2**31)))  # randomConfiguration's generator is Pinocchio's global one
    for robot in (planar3, panda):
        for _ in range(3):
            q = pin.randomConfiguration(robot.model) if robot is panda else rng.uniform(-2, 2, 3)
            xdot = rng.normal(size=robot.m)
            rates = joint_rates(robot, "kinetic-energy-pinv", q, xdot)
            inertia = pin.crba(robot.model, robot.model.createData(), q)
            inertia = np.triu(inertia) + np.triu(inertia, 1).T
            jacobian = FrameTask(robot.frame, robot.task).jacobian(Kinematics(robot).update(q))
            # min ½ q̇ᵀHq̇ subject to J q̇ = ẋ: [H Jᵀ; J 0][q̇; λ] = [0; ẋ]
            n, m = robot.nv, robot.m
            kkt = np.block([[inertia, jacobian.T], [jacobian, np.zeros((m, m))]])
            expected = np.linalg.solve(kkt, np.concatenate([np.zeros(n), xdot]))[:n]
            np.testing.assert_allclose(rates, expected, atol=1e-9)
            basis = np.linalg.svd(jacobian)[2][m:].T
            energy = 0.5 * rates.dot(inertia).dot(rates)  # Eq. (17)
            for _ in range(5):
                other = rates + basis.dot(rng.normal(size=n - m))
                assert 0.5 * other.dot(inertia).dot(other) > energy


def test_the_inverse_inertia_is_pinocchios_python_computeminverse_symmetric_and_fresh(panda, rng):
    """kinetic-energy-pinv reads H⁻¹ from Pinocchio's Python ``computeMinverse``, whose binding fills the lower
    triangle the C++ function leaves (held here to the inverse of CRBA's H) and returns a new array each call."""
    pin.seed(int(rng.integers(2**31)))
    kinematics = Kinematics(panda)
    first = inverse_inertia_at(kinematics.update(pin.randomConfiguration(panda.model)))
    kept = first.copy()
    for _ in range(3):
        q = pin.randomConfiguration(panda.model)
        inertia = pin.crba(panda.model, panda.model.createData(), q)
        inertia = np.triu(inertia) + np.triu(inertia, 1).T
        np.testing.assert_allclose(
            inverse_inertia_at(kinematics.update(q)), np.linalg.inv(inertia), rtol=1e-10, atol=1e-10
        )
    np.testing.assert_array_equal(first, kept)


def test_joint_limit_gradient_is_that_of_eq_5(panda, rng):
    pin.seed(int(rng.integers(2**31)))  # randomConfiguration's generator is Pinocchio's global one
    criterion = JointLimits()
    lower, upper = panda.model.lowerPositionLimit, panda.model.upperPositionLimit
    for _ in range(3):
        q = pin.randomConfiguration(panda.model)
        kinematics = Kinematics(panda).update(q)
        assert criterion.value(kinematics) == pytest.approx(closed_form_joint_limits(q, lower, upper), rel=1e-12)
        np.testing.assert_allclose(
            criterion.gradient(kinematics), central(lambda x: closed_form_joint_limits(x, lower, upper), q), atol=1e-7
        )
        np.testing.assert_allclose(
            criterion.hessian(kinematics), central(criterion_gradient_at(panda, criterion), q), atol=1e-6
        )


def test_scaled_gradients_are_the_gain_times_the_gradient(planar3, panda, rng):
    """k ∂p/∂q of the joint limits (the gain joined to Eq. (5)'s constant diagonal), of a posture's distance
    (k(q − q*) from the configuration) and of the manipulability (w and J⁺ from the resolver's own SVD of J)
    against k times the readable gradient; on kinova, whose continuous joints do not add, the posture takes
    the readable path."""
    from torqueopt.linalg import JacobianSolver
    from torqueopt.resolvers.velocity import Manipulability
    from torqueopt.resolvers.velocity.criteria import PostureDistance

    pin.seed(int(rng.integers(2**31)))  # randomConfiguration's generator is Pinocchio's global one
    kinova = torqueopt.load_robot("kinova", task="position")
    cases = [
        (planar3, JointLimits()),
        (panda, JointLimits()),
        (planar3, PostureDistance(PostureTask(gain=2.5))),
        (panda, PostureDistance(PostureTask(target=rng.uniform(-1.0, 1.0, panda.nv), gain=0.7))),
        (kinova, PostureDistance(PostureTask(gain=3.0))),
        (planar3, Manipulability()),
        (panda, Manipulability()),
    ]
    for robot, criterion in cases:
        if isinstance(criterion, PostureDistance):
            criterion.posture.check(robot)
        task, solver = FrameTask.of_robot(robot), JacobianSolver(robot.m, robot.nv, 1e-6, null_space=False)
        for gain in (0.3, 10.0, 0.3):  # a new gain, and back: nothing of the former one is kept
            for _ in range(2):
                kinematics = Kinematics(robot).update(pin.randomConfiguration(robot.model))
                solver.inverse_condition(task.jacobian(kinematics))
                expected = gain * criterion.gradient(kinematics, task)
                for decomposition in (None, solver):
                    got = criterion.scaled_gradient(kinematics, task, gain, decomposition)
                    np.testing.assert_allclose(got, expected, rtol=1e-13, atol=1e-13 * np.abs(expected).max())


def test_scaled_curvatures_are_the_gain_times_the_curvature(planar3, panda, rng):
    """k ∇²p q̇ of the manipulability (closed form, the gain joined to w) and of the joint limits against k
    times the curvature, and the manipulability's against a central difference of k ∂p/∂q along q̇; the caller's
    kinematics are left where they were."""
    from torqueopt.resolvers.velocity import Manipulability

    pin.seed(int(rng.integers(2**31)))  # randomConfiguration's generator is Pinocchio's global one
    for robot, criterion in ((planar3, Manipulability()), (panda, Manipulability()), (panda, JointLimits())):
        task = FrameTask.of_robot(robot)
        for gain in (0.3, 10.0):
            q, v = pin.randomConfiguration(robot.model), rng.normal(size=robot.nv)
            kinematics = Kinematics(robot).update(q)
            revision = kinematics.revision
            expected = gain * criterion.curvature(kinematics, task, v)
            got = criterion.scaled_curvature(kinematics, task, v, gain)
            np.testing.assert_allclose(got, expected, rtol=0, atol=1e-9 * np.abs(expected).max())
            assert kinematics.revision == revision and kinematics.q is q
            along = central(lambda x: gain * criterion.gradient(Kinematics(robot).update(x), task), q).dot(v)
            np.testing.assert_allclose(got, along, rtol=0, atol=1e-6 * np.abs(expected).max())


def test_a_manipulability_resolver_pickles_after_a_run(planar3):
    """The manipulability keeps a Kinematics and an SVD object for its differences; a resolver that has run
    still pickles (as one sent to a worker does), and its copy runs as the original."""
    import pickle

    resolver = torqueopt.get_resolver("gradient-projection", criterion="manipulability")
    trajectory = torqueopt.StraightLine([1.0, 1.0], duration=2.0)
    first = torqueopt.simulate(planar3, resolver, trajectory, PAPER_Q0, duration=0.02)
    copy = pickle.loads(pickle.dumps(resolver))
    again = torqueopt.simulate(planar3, copy, trajectory, PAPER_Q0, duration=0.02)
    np.testing.assert_array_equal(again.tau, first.tau)


def criterion_gradient_at(robot, criterion, task=None):
    return lambda x: criterion.gradient(Kinematics(robot).update(x), task)


def test_manipulability_gradient_from_the_kinematic_hessian_matches_differences(planar3, panda, rng):
    """∂w/∂q from Pinocchio's kinematic Hessian against central differences of w: the closed-form
    planar w of Eq. (6) for the paper's arm, w of Pinocchio's Jacobian for panda."""
    pin.seed(int(rng.integers(2**31)))  # randomConfiguration's generator is Pinocchio's global one
    criterion = torqueopt.resolvers.velocity.Manipulability()
    for robot, w_of in ((planar3, closed_form_manipulability), (panda, None)):
        task = FrameTask(robot.frame, robot.task)
        if w_of is None:

            def w_of(x, robot=robot, task=task):
                return manipulability(task.jacobian(Kinematics(robot).update(x)))

        for _ in range(3):
            q = pin.randomConfiguration(robot.model) if robot is panda else rng.uniform(-2, 2, 3)
            kinematics = Kinematics(robot).update(q)
            assert -criterion.value(kinematics, task) == pytest.approx(w_of(q), rel=1e-10)
            np.testing.assert_allclose(-criterion.gradient(kinematics, task), central(w_of, q), atol=1e-7)


def test_gradient_projection_is_eq_4_and_descends_its_criterion(planar3, panda, rng):
    pin.seed(int(rng.integers(2**31)))  # randomConfiguration's generator is Pinocchio's global one
    for robot, criterion, k in (
        (planar3, "manipulability", 2.0),
        (panda, "joint-limits", 3.0),
        (panda, "manipulability", 1.0),
    ):
        resolver = torqueopt.get_resolver("gradient-projection", criterion=criterion, k=k)
        task = FrameTask(robot.frame, robot.task)
        for _ in range(3):
            q = pin.randomConfiguration(robot.model) if robot is panda else rng.uniform(-2, 2, 3)
            xdot = rng.normal(size=robot.m)
            kinematics = Kinematics(robot).update(q)
            jacobian = task.jacobian(kinematics)
            gradient = resolver.objective.gradient(kinematics, task)
            pinv = np.linalg.pinv(jacobian)
            expected = pinv.dot(xdot) - k * (np.eye(robot.nv) - pinv.dot(jacobian)).dot(gradient)  # Eq. (4)
            rates = joint_rates(robot, resolver, q, xdot)
            np.testing.assert_allclose(rates, expected, atol=1e-9)
            np.testing.assert_allclose(jacobian.dot(rates), xdot, atol=1e-9)
            # with the tip at rest the criterion can only fall: ṗ = −k‖(I − J⁺J)∇p‖² ≤ 0
            assert gradient.dot(joint_rates(robot, resolver, q, np.zeros(robot.m))) <= 1e-12


def test_a_callable_criterion_gets_its_gradient_by_differences(planar3):
    resolver = torqueopt.get_resolver(
        "gradient-projection", criterion=lambda angles: float(np.sum(np.sin(angles) ** 2)), k=1.0
    )
    q = np.array([0.3, 1.1, -0.7])
    kinematics = Kinematics(planar3).update(q)
    np.testing.assert_allclose(resolver.objective.gradient(kinematics), np.sin(2 * q), atol=1e-8)
    np.testing.assert_allclose(resolver.objective.hessian(kinematics), np.diag(2 * np.cos(2 * q)), atol=1e-4)


def test_extended_jacobian_is_eqs_14_and_15(planar3, rng):
    resolver = torqueopt.get_resolver("extended-jacobian")
    task = FrameTask("tip", "xy")

    def g_at(x):
        return resolver.extended_row(Kinematics(planar3).update(x), task)[0]

    for _ in range(4):
        q, xdot = rng.uniform(-2, 2, 3), rng.normal(size=2)
        kinematics = Kinematics(planar3).update(q)
        g_value, g_row, normal = resolver.extended_row(kinematics, task)
        jacobian = planar_jacobian(q)
        np.testing.assert_allclose(jacobian.dot(normal), 0.0, atol=1e-12)
        np.testing.assert_allclose(
            normal, np.cross(jacobian[0], jacobian[1]), atol=1e-12
        )  # "cross products of columns"
        gradient = 2 * q / (2 * np.pi) ** 2  # Eq. (5) with the URDF's ±2π limits
        assert g_value == pytest.approx(gradient.dot(normal), abs=1e-12)  # Eq. (14)
        np.testing.assert_allclose(g_row, central(g_at, q), atol=1e-7)
        rates = joint_rates(planar3, resolver, q, xdot)
        np.testing.assert_allclose(
            np.vstack([jacobian, g_row]).dot(rates), np.append(xdot, 0.0), atol=1e-10
        )  # Eq. (15)


def assert_stacked_step_is_the_lu_reference(kinematics, fast, reference, draw_q, rng, count):
    """The extended Jacobian's stacked form on a stack of one (the row and the curvature in closed form from the
    frame's J and J̇, J_ex⁻¹ by its adjugate) against its single-state step,
    :meth:`ExtendedJacobian.lu_step_functions` (the row from Pinocchio's kinematic Hessian, J_ex's LU factors, the
    curvature in closed form from the cofactors' rates) at ``count`` drawn states where J is not singular: q̇,
    σmin/σmax and q̈ at 1e-12; two computations, which differ somewhere in the last bits."""
    tested, differ = 0, False
    while tested < count:
        q = draw_q()
        velocity = rng.normal(size=q.size)
        command, command_rate = rng.normal(size=2), rng.normal(size=2)
        try:
            expected_rates, expected_condition = reference[0](kinematics.update(q), command)
        except SingularJacobian:
            continue
        tested += 1
        got_rates, got_condition = fast[0](kinematics, command)
        np.testing.assert_allclose(got_rates, expected_rates, rtol=0, atol=1e-12 * np.abs(expected_rates).max())
        assert got_condition == pytest.approx(expected_condition, rel=1e-12)
        expected = reference[1](kinematics, velocity, command, command_rate)
        got = fast[1](kinematics.update(q), velocity, command, command_rate)
        np.testing.assert_allclose(got, expected, rtol=0, atol=1e-12 * np.abs(expected).max())
        differ = differ or not np.array_equal(got, expected) or not np.array_equal(got_rates, expected_rates)
    assert differ  # two computations, not one


@pytest.mark.parametrize("gain", [0.0, 5.0])
def test_the_extended_jacobian_step_is_its_lu_reference(planar3, rng, gain):
    """planar3's stacked form on a stack of one (cross products, J_ex⁻¹ by its adjugate, J's inverse condition
    from JJᵀ) against its single-state step, :meth:`ExtendedJacobian.lu_step_functions` (J_ex's LU factors, Eigen's
    SVD, the curvature by its central difference), and the same refusals with the same words where J or J_ex is
    singular."""
    resolver = torqueopt.get_resolver("extended-jacobian", position_gain=gain)
    task = FrameTask.of_robot(planar3)
    fast, reference = stacked_steps(resolver, planar3, task), resolver.step_functions(planar3, task)
    assert reference[0].__qualname__.startswith("ExtendedJacobian.lu_step_functions")
    kinematics = Kinematics(planar3)
    assert_stacked_step_is_the_lu_reference(kinematics, fast, reference, lambda: rng.uniform(-2, 2, 3), rng, count=10)
    command = rng.normal(size=2)
    # stretched (J of rank 1), nearly stretched, and with an alignment cutoff most states miss
    strict = torqueopt.get_resolver("extended-jacobian", algorithmic_tolerance=0.9)
    cases = [(resolver, np.zeros(3)), (resolver, np.array([0.0, 1e-7, 0.0]))]
    cases += [(strict, rng.uniform(-2, 2, 3)) for _ in range(10)]
    refused = 0
    for method, q in cases:
        messages = []
        for rates, _ in (stacked_steps(method, planar3, task), method.step_functions(planar3, task)):
            try:
                rates(kinematics.update(q), command)
                messages.append(None)
            except SingularJacobian as error:
                messages.append(str(error))
        assert messages[0] == messages[1]
        refused += messages[0] is not None
    assert refused >= 4


def test_task_priority_realises_the_high_priority_task_exactly_and_is_eqs_9_and_10(planar3, rng):
    elbow = FrameTask("link3", "xy", target=ELBOW_TARGET, gain=2.0)
    resolver = torqueopt.get_resolver("task-priority", secondary=elbow)
    for _ in range(5):
        q, xdot = rng.uniform(-2, 2, 3), rng.normal(size=2)
        rates = joint_rates(planar3, resolver, q, xdot)
        high = planar_jacobian(q)
        angles = np.cumsum(q)
        low = np.array([[-np.sin(angles[0]) - np.sin(angles[1]), -np.sin(angles[1]), 0.0],
                        [np.cos(angles[0]) + np.cos(angles[1]), np.cos(angles[1]), 0.0]])  # fmt: skip
        x_low = 2.0 * (np.array(ELBOW_TARGET) - planar_points(q)[2])
        high_pinv = np.linalg.pinv(high)
        projector = np.eye(3) - high_pinv.dot(high)
        phi = np.linalg.pinv(low.dot(projector), rcond=1e-10).dot(x_low - low.dot(high_pinv).dot(xdot))  # Eq. (10)
        np.testing.assert_allclose(rates, high_pinv.dot(xdot) + projector.dot(phi), atol=1e-10)  # Eq. (9)
        np.testing.assert_allclose(high.dot(rates), xdot, atol=1e-12)  # Eq. (7) realised exactly


def test_obstacle_avoidance_is_eqs_12_and_13(planar3, rng):
    obstacle = ObstacleTask(OBSTACLE[:3], OBSTACLE[3], speed=0.4)
    resolver = torqueopt.get_resolver("obstacle-avoidance", obstacle=obstacle, influence=10.0, critical=5.0)
    for _ in range(4):
        q, xdot = rng.uniform(-2, 2, 3), rng.normal(size=2)
        kinematics = Kinematics(planar3).update(q)
        closest = obstacle.closest_point(kinematics)
        point_jacobian = obstacle.point_jacobian(kinematics, closest)
        jacobian = planar_jacobian(q)
        pinv = np.linalg.pinv(jacobian)
        projector = np.eye(3) - pinv.dot(jacobian)
        phi = np.linalg.pinv(point_jacobian.dot(projector), rcond=1e-10).dot(
            0.4 * closest.normal - point_jacobian.dot(pinv).dot(xdot)
        )  # Eq. (12)
        rates = joint_rates(planar3, resolver, q, xdot)
        np.testing.assert_allclose(rates, pinv.dot(xdot) + phi, atol=1e-9)  # Eq. (13) with α_h = 1
        np.testing.assert_allclose(jacobian.dot(rates), xdot, atol=1e-10)


def test_the_avoidance_switches_on_smoothly():
    assert activation(0.6, 0.5, 0.1) == 0.0 and activation(0.05, 0.5, 0.1) == 1.0
    assert activation(0.3, 0.5, 0.1) == pytest.approx(0.5)
    assert 0.0 < activation(0.45, 0.5, 0.1) < 0.1


# -- runs: torques by inverse dynamics on the motion ----------------------------------------


@pytest.mark.parametrize(
    "resolver",
    ["velocity-pinv", "kinetic-energy-pinv", torqueopt.get_resolver("velocity-pinv", position_gain=5.0)],
    ids=["velocity-pinv", "kinetic-energy-pinv", "velocity-pinv-closed-loop"],
)
def test_the_kinematic_loop_converges_at_fourth_order(planar3, resolver):
    """RK4 on q̇ = f(q, t): the end configuration's error falls by 2⁴ = 16 when dt halves.

    The error at step h is estimated by q_h(T) − q_{h/2}(T), itself C h⁴ (1 − 1/16) for a fourth-order
    method, so successive differences fall by 16 (Euler: 2, midpoint: 4). Every dt divides T/2, where the
    reference acceleration jumps, so f is smooth within each step.
    """
    finals = [
        torqueopt.simulate(planar3, resolver, LONG, PAPER_Q0, dt=dt).q[-1] for dt in (0.05, 0.025, 0.0125, 0.00625)
    ]
    differences = [np.linalg.norm(coarse - fine) for coarse, fine in zip(finals, finals[1:])]
    ratios = np.array(differences[:-1]) / differences[1:]
    assert ((ratios > 14.0) & (ratios < 18.5)).all(), ratios
    assert differences[-1] < 1e-7  # and well above round-off: ~3e-10 to 1e-8 [rad]


#: The methods run on the paper's long movement: key -> (resolver, options).
LONG_CASES = {
    "velocity-pinv": ("velocity-pinv", {}),
    "gradient-projection": ("gradient-projection", {"k": 30.0}),
    "manipulability": ("gradient-projection", {"criterion": "manipulability", "k": 1.0}),
    "kinetic-energy-pinv": ("kinetic-energy-pinv", {}),
    "extended-jacobian": ("extended-jacobian", {}),
    "task-priority": ("task-priority", {"secondary": FrameTask("link3", "xy", target=ELBOW_TARGET)}),
    "obstacle-avoidance": ("obstacle-avoidance", {"obstacle": OBSTACLE}),
    "pinv": ("pinv", {}),
    "null-space": ("null-space", {}),
}
KINEMATIC_CASES = [key for key in LONG_CASES if key not in ("pinv", "null-space")]


@pytest.fixture(scope="module")
def long_runs(planar3):
    """The paper's long movement with every velocity-level method (and the torque methods beside),
    by key of :data:`LONG_CASES`: each run is simulated the first time a test asks for it, then kept."""
    runs = {}

    def run(key):
        if key not in runs:
            name, options = LONG_CASES[key]
            runs[key] = torqueopt.simulate(planar3, name, LONG, PAPER_Q0, resolver_options=options)
        return runs[key]

    return run


@pytest.mark.slow
def test_every_kinematic_run_tracks_the_line_and_records_consistent_torques(long_runs, planar3):
    """q̈ of the record matches differences of its q̇ (away from the reference's jumps at 0 and T/2),
    the task acceleration is met, and the power τ·q̇ equals dT/dt (no gravity on the paper's arm)."""
    data = planar3.model.createData()
    for key in KINEMATIC_CASES:
        result = long_runs(key)
        assert result.completed, key
        assert result.max_tip_error < 1e-9, key
        differences = np.gradient(result.v, result.dt, axis=0)
        smooth = np.ones(len(result.t), bool)
        smooth[[0, 999, 1000, 1001, -1]] = False
        kinematics, task = Kinematics(planar3), FrameTask("tip", "xy")
        shortfall = []
        for q, v, a, reference in zip(
            result.q, result.v, result.acceleration, LONG.anchored(result.x[0]).sample(result.t).acceleration
        ):
            kinematics.update(q, v)
            shortfall.append(np.linalg.norm(task.jacobian(kinematics).dot(a) + task.drift(kinematics) - reference))
        assert np.max(np.asarray(shortfall)[smooth]) < 1e-6, key  # Eq. (18): the motion's q̈ realises ẍ_ref
        scale = 1 + np.abs(result.acceleration).max()
        mismatch = np.abs(result.acceleration - differences)[smooth].max(axis=1)
        # the closest point of obstacle-avoidance jumps between links, a kink in q̇ at a few steps
        share = 0.99 if key == "obstacle-avoidance" else 1.0
        assert np.quantile(mismatch, share) < 1e-4 * scale, key
        energy = np.array([0.5 * v.dot(pin.crba(planar3.model, data, q)).dot(v) for q, v in zip(result.q, result.v)])
        power = np.einsum("ij,ij->i", result.tau, result.v)
        power_mismatch = np.abs(np.gradient(energy, result.dt) - power)[smooth]
        assert np.quantile(power_mismatch, share) < 1e-4 * scale * (1 + np.abs(power).max()), key


def test_joint_limit_gradient_projection_keeps_joints_nearer_mid_range(long_runs, planar3):
    criterion = JointLimits()
    mean_p = {
        key: np.mean([criterion.value(Kinematics(planar3).update(q)) for q in long_runs(key).q])
        for key in ("velocity-pinv", "gradient-projection")
    }
    assert mean_p["gradient-projection"] < 0.9 * mean_p["velocity-pinv"]


@pytest.mark.slow
def test_manipulability_gradient_projection_keeps_w_higher(long_runs, planar3):
    mean_w = {
        key: np.mean([closed_form_manipulability(q) for q in long_runs(key).q])
        for key in ("velocity-pinv", "manipulability")
    }
    assert mean_w["manipulability"] > 1.02 * mean_w["velocity-pinv"]
    assert closed_form_manipulability(long_runs("manipulability").q[-1]) > closed_form_manipulability(
        long_runs("velocity-pinv").q[-1]
    )


@pytest.mark.slow
def test_the_secondary_task_moves_the_elbow_to_its_target_without_touching_the_tip(long_runs):
    """The elbow lies on the unit circle about the tip, so the best it can do is |x_tip − target| − 1:
    the low-priority task reaches that insofar-as-possible optimum while the tip stays on its path."""

    def elbow_miss(result):
        return np.array([np.linalg.norm(planar_points(q)[2] - ELBOW_TARGET) for q in result.q])

    priority, plain = long_runs("task-priority"), long_runs("velocity-pinv")
    assert priority.max_tip_error < 1e-9
    assert elbow_miss(priority).mean() < 0.75 * elbow_miss(plain).mean()
    best = np.linalg.norm(priority.x[-1] - ELBOW_TARGET) - 1.0
    assert elbow_miss(priority)[-1] == pytest.approx(best, abs=2e-3) and elbow_miss(plain)[-1] > best + 0.2


@pytest.mark.slow
def test_obstacle_avoidance_increases_the_clearance(long_runs, planar3):
    obstacle = ObstacleTask.from_spec(OBSTACLE)

    def clearance(result):
        kinematics = Kinematics(planar3)
        return min(obstacle.clearance(kinematics.update(q)) for q in result.q)

    assert clearance(long_runs("velocity-pinv")) < 0.0  # the plain pseudoinverse runs the arm through it
    assert clearance(long_runs("obstacle-avoidance")) > 0.2


@pytest.mark.slow
def test_the_kinematic_pseudoinverse_does_not_whip_where_the_null_space_method_does(long_runs):
    """The paper's contrast, on the velocity-level resolved rate: no whiplash on the long movement."""
    assert detect_whiplash(long_runs("null-space")).unstable
    for key in ("velocity-pinv", "kinetic-energy-pinv", "extended-jacobian"):
        assert not detect_whiplash(long_runs(key)).unstable, key


# -- repeatability (Klein & Huang) ------------------------------------------------------------


def test_pinv_drifts_after_one_loop_and_the_extended_jacobian_does_not(planar3):
    drift = {}
    for name in ("velocity-pinv", "extended-jacobian"):
        result = torqueopt.simulate(planar3, name, LOOP, PAPER_Q0, dt=0.005)
        assert result.completed and np.linalg.norm(result.x[-1] - result.x[0]) < 1e-9
        drift[name] = np.abs(result.joint_angles[-1] - result.joint_angles[0]).max()
    assert drift["velocity-pinv"] > 0.2  # rad: Klein & Huang's non-repeatability
    assert drift["extended-jacobian"] < 1e-6


@pytest.mark.slow
def test_the_extended_jacobian_stops_cleanly_at_its_algorithmic_singularity(planar3):
    """On the circle centred toward the base the surface G = G(q0) folds: the run stops, saying where it stood."""
    result = torqueopt.simulate(planar3, "extended-jacobian", torqueopt.Circle(0.3, 4.0), PAPER_Q0, dt=0.005)
    assert not result.completed and 1.0 < result.stop_time < 2.0
    assert result.stop_reason.startswith(
        "extended Jacobian is singular (an algorithmic singularity of Baillieul's method)"
    )
    alignment = float(
        re.search(r"\|∂G/∂q·n\|/\(\|∂G/∂q\| \|n\|\) = ([0-9.e+-]+) is below the cutoff 0.05", result.stop_reason).group(
            1
        )
    )
    assert alignment < 0.05  # against 0.65 at q0: the fold, reached within one step
    # at 1 ms the torques pass the ceiling first (they grow as the alignment's inverse cube); the reason says where it stood
    fine = torqueopt.simulate(planar3, "extended-jacobian", torqueopt.Circle(0.3, 4.0), PAPER_Q0, dt=0.001)
    assert (
        fine.stop_reason.startswith("torque of joint joint3")
        and "the extended Jacobian's alignment" in fine.stop_reason
    )
    assert abs(fine.stop_time - result.stop_time) < 0.01
    # the rates run away as the fold nears: the last speeds are several times those a quarter of the way
    speed = np.abs(result.v).max(axis=1)
    assert speed[-1] > 3 * speed[len(speed) // 4]


# -- every method on a 7-joint arm, and the errors ---------------------------------------------


@pytest.mark.parametrize(
    "name, options",
    [
        ("velocity-pinv", {}),
        ("gradient-projection", {"k": 3.0}),
        ("gradient-projection", {"criterion": "manipulability"}),
        ("kinetic-energy-pinv", {}),
        ("task-priority", {"secondary": FrameTask("panda_link4", "position", target=[0.3, 0.0, 0.6])}),
        ("obstacle-avoidance", {"obstacle": [0.4, 0.2, 0.5, 0.05]}),
    ],
)
def test_every_velocity_method_tracks_a_line_on_panda(name, options, panda):
    line = torqueopt.StraightLine([0, 1, 0], accel=0.5, duration=0.6)
    result = torqueopt.simulate(panda, name, line, panda.default_configuration, dt=0.005, resolver_options=options)
    assert result.completed and result.max_tip_error < 1e-8 and np.isfinite(result.tau).all()


def test_kinematic_resolvers_refuse_what_does_not_apply(planar3, panda):
    with pytest.raises(InvalidInput, match="resolver 'velocity-pinv' resolves joint velocities, not torques"):
        torqueopt.resolve(planar3, "velocity-pinv", PAPER_Q0, np.zeros(3), [1.0, 0.0])
    with pytest.raises(InvalidInput, match="v0 must be None or zero"):
        torqueopt.simulate(planar3, "velocity-pinv", LONG, PAPER_Q0, v0=[0.1, 0, 0])
    with pytest.raises(InvalidInput, match="give it position_gain= \\[1/s\\] instead"):
        torqueopt.simulate(planar3, "velocity-pinv", LONG, PAPER_Q0, feedback=(1.0, 1.0))
    with pytest.raises(
        NoRedundancy,
        match=r"needs exactly one degree of redundancy \(n − m = 1\); task 'position' on robot 'panda' leaves 4",
    ):
        torqueopt.simulate(panda, "extended-jacobian", LONG, panda.default_configuration)
    with pytest.raises(InvalidInput, match="needs the option obstacle"):
        torqueopt.simulate(planar3, "obstacle-avoidance", LONG, PAPER_Q0)
    with pytest.raises(InvalidInput) as error:
        torqueopt.get_resolver("gradient-projection", criterion="dexterity")
    assert str(error.value) == (
        "option criterion=dexterity of resolver 'gradient-projection' must be one of joint-limits, manipulability, "
        "a Criterion or a callable p(joint_angles)"
    )
    with pytest.raises(
        InvalidInput, match="option criterion=manipulability of resolver 'extended-jacobian' has no Hessian here"
    ):
        torqueopt.get_resolver("extended-jacobian", criterion="manipulability")
    with pytest.raises(InvalidInput, match="must be below influence=0.5"):
        torqueopt.get_resolver("obstacle-avoidance", obstacle=OBSTACLE, critical=0.7)


def test_the_cli_runs_a_kinematic_method_with_its_options(tmp_path, capsys):
    out = tmp_path / "run.csv"
    code = main(["run", "--robot", "planar3", "--q0=-45,135,-135", "--degrees", "--direction", "1,1", "--duration", "0.5",
                 "--resolver", "obstacle-avoidance", "--option", "obstacle=1.2,0.3,0,0.1", "--out", str(out)])  # fmt: skip
    printed = capsys.readouterr().out
    assert code == 0 and "resolver obstacle-avoidance" in printed and "status: completed" in printed
    assert np.loadtxt(out, delimiter=",", skiprows=1).shape[0] == 501
    code = main(["run", "--robot", "planar3", "--direction", "1,1", "--resolver", "task-priority",
                 "--option", "secondary=link3:0.5,-0.5", "--duration", "0.2"])  # fmt: skip
    assert code == 0
    assert main(["run", "--robot", "planar3", "--direction", "1,1", "--resolver", "obstacle-avoidance"]) == 2
    assert "needs the option obstacle" in capsys.readouterr().err


def test_task_priority_defaults_to_a_posture_task_toward_the_default_configuration(planar3, rng):
    """Without a secondary task the lower priority is every joint toward the robot's default
    configuration: [P]⁺(k(q* − q) − J⁺ẋ) = P k (q* − q), the projected posture error."""
    resolver = torqueopt.get_resolver("task-priority")
    target = planar3.joint_angles(planar3.default_configuration)
    for _ in range(3):
        q, xdot = rng.uniform(-2, 2, 3), rng.normal(size=2)
        jacobian = planar_jacobian(q)
        pinv = np.linalg.pinv(jacobian)
        projector = np.eye(3) - pinv.dot(jacobian)
        np.testing.assert_allclose(
            joint_rates(planar3, resolver, q, xdot), pinv.dot(xdot) + projector.dot(target - q), atol=1e-10
        )


def test_task_priority_below_postures_runs_as_gradient_projection_and_is_the_recursion_of_eq_11(panda, rng):
    """Below posture tasks only, the resolver takes Eq. (11) as gradient projection toward the first posture
    (one SVD, not two): its rates against the recursion itself (tasks.prioritised_rates) with every posture,
    the second adding nothing (the first leaves no freedom)."""
    pin.seed(int(rng.integers(2**31)))
    first, second = PostureTask(gain=2.0), PostureTask(target=rng.uniform(-1, 1, panda.nv), gain=3.0)
    resolver = torqueopt.get_resolver("task-priority", secondary=[first, second])
    task, kinematics = FrameTask.of_robot(panda), Kinematics(panda)
    for _ in range(4):
        q, xdot = pin.randomConfiguration(panda.model), rng.normal(size=panda.m)
        rates = joint_rates(panda, resolver, q, xdot)
        kinematics.update(q)
        jacobians = [task.jacobian(kinematics), np.eye(panda.nv), np.eye(panda.nv)]
        velocities = [xdot, first.desired_velocity(kinematics), second.desired_velocity(kinematics)]
        np.testing.assert_allclose(rates, prioritised_rates(jacobians, velocities)[0], rtol=0, atol=1e-12)


def test_gradient_projection_at_the_acceleration_level(planar3, rng):
    """q̈ = J⁺(ẍ − J̇q̇) − (I − J⁺J)(k ∂p/∂q + k_d q̇), with the closed-form planar J and Eq. (5)'s gradient."""
    resolver = torqueopt.get_resolver("gradient-projection-acceleration", k=3.0, damping=2.0)
    for _ in range(4):
        q, v, xdd = rng.uniform(-2, 2, 3), rng.normal(size=3), rng.normal(size=2)
        terms = planar3.terms(q, v)
        resolution = resolver.resolve(planar3, terms, xdd)
        jacobian = planar_jacobian(q)
        pinv = np.linalg.pinv(jacobian)
        gradient = 2 * q / (2 * np.pi) ** 2
        expected = pinv.dot(xdd - terms.drift) - (np.eye(3) - pinv.dot(jacobian)).dot(3.0 * gradient + 2.0 * v)
        np.testing.assert_allclose(resolution.joint_acceleration, expected, atol=1e-10)


def test_task_priority_at_the_acceleration_level_is_eq_11_differentiated(panda, rng):
    """q̈ = p + [J_l P]⁺(ẍ_l − J̇_l q̇ − J_l p), p = J⁺(ẍ − J̇q̇), P = I − J⁺J, against the resolver's null-space form."""
    pin.seed(int(rng.integers(2**31)))  # randomConfiguration's generator is Pinocchio's global one
    elbow = FrameTask("panda_link4", "position", target=[0.3, 0.0, 0.6])
    resolver = torqueopt.get_resolver("task-priority-acceleration", secondary=elbow, stiffness=16.0, damping=8.0)
    for _ in range(3):
        q, v, xdd = pin.randomConfiguration(panda.model), rng.normal(size=7), rng.normal(size=3)
        terms = panda.terms(q, v)
        resolution = resolver.resolve(panda, terms, xdd)
        pinv = np.linalg.pinv(terms.jacobian)
        particular = pinv.dot(xdd - terms.drift)
        projector = np.eye(7) - pinv.dot(terms.jacobian)
        kinematics = Kinematics(panda).update(q, v)
        low = elbow.jacobian(kinematics)
        desired = 16.0 * (np.array([0.3, 0.0, 0.6]) - elbow.value(kinematics)) - 8.0 * low.dot(v)
        expected = particular + np.linalg.pinv(low.dot(projector), rcond=1e-10).dot(
            desired - elbow.drift(kinematics) - low.dot(particular)
        )
        np.testing.assert_allclose(resolution.joint_acceleration, expected, atol=1e-8)
        np.testing.assert_allclose(terms.jacobian.dot(resolution.joint_acceleration) + terms.drift, xdd, atol=1e-9)


def test_a_kinematic_run_keeps_the_urdf_joint_limits_as_a_torque_run_does(planar3):
    """Both loops build their result the same way: the joint limits of the URDF
    (planar3: ±2π rad, 100 rad/s) are in a velocity-level run's result too."""
    line = torqueopt.StraightLine([1, 1], duration=0.2)
    kinematic = torqueopt.simulate(planar3, "velocity-pinv", line, PAPER_Q0)
    kinetic = torqueopt.simulate(planar3, "pinv", line, PAPER_Q0)
    assert np.array_equal(kinematic.velocity_limit, [100.0, 100.0, 100.0])
    assert np.allclose(kinematic.position_upper, 2 * np.pi) and np.allclose(kinematic.position_lower, -2 * np.pi)
    assert kinematic.joint_limits == kinetic.joint_limits and kinematic.trajectory == kinetic.trajectory


def test_task_priority_with_a_tiny_damping_keeps_the_torques_of_no_damping(planar3):
    """The issue's case: damping=1e-6 gave joint 3 662 N·m where damping=0 gives 4.9 N·m."""
    resolver_plain = torqueopt.get_resolver("task-priority")
    plain = torqueopt.simulate(planar3, resolver_plain, torqueopt.StraightLine((1.0, 1.0), duration=0.5), PAPER_Q0)
    for damping in (1e-6, 1e-12):
        damped = torqueopt.simulate(
            planar3,
            torqueopt.get_resolver("task-priority", damping=damping),
            torqueopt.StraightLine((1.0, 1.0), duration=0.5),
            PAPER_Q0,
        )
        assert damped.completed
        np.testing.assert_allclose(np.abs(damped.tau).max(axis=0), np.abs(plain.tau).max(axis=0), rtol=1e-3)


def test_extended_jacobian_on_a_robot_with_more_redundancy_says_what_would_work(capsys):
    """On kinova (n = 6, position task) it suggested "a task with m = 5", which no task has."""
    code = main(["run", "--robot", "kinova", "--resolver", "extended-jacobian", "--direction", "0,1,0",
                 "--duration", "0.2"])  # fmt: skip
    assert code == 2
    assert capsys.readouterr().err == (
        "torqueopt run: error: resolver 'extended-jacobian' needs exactly one degree of redundancy (n − m = 1); "
        "task 'position' on robot 'kinova' leaves 3: lock 2 joints of the chain (--lock NAME,...) so that n = 4, "
        "or choose a resolver that takes any redundancy (velocity-pinv, gradient-projection)\n"
    )


def test_the_stacked_inverse_is_lapacks_with_identity_rows_where_the_method_fails(rng):
    """The velocity-level stacks' G⁻¹ (closed form for two rows) against numpy's LAPACK inverse, for symmetric and
    non-symmetric 2×2 and for 3×3 stacks; a failed row's answer is the identity's inverse, whatever its matrix."""
    from torqueopt.resolvers.velocity.pseudoinverse import stacked_inverse

    for m in (2, 3):
        factors = rng.normal(size=(9, m, m + 2))
        for gram in (factors @ np.swapaxes(factors, 1, 2), rng.normal(size=(9, m, m)) + 3.0 * np.eye(m)):
            expected = np.linalg.inv(gram)
            singular = gram.copy()
            singular[4] = 0.0  # a row whose method failed: its matrix need not be invertible
            inverse = stacked_inverse(singular, {4: "singular"})
            rows = [row for row in range(9) if row != 4]
            np.testing.assert_allclose(inverse[rows], expected[rows], rtol=1e-12, atol=1e-12)
            np.testing.assert_array_equal(inverse[4], np.eye(m))


def test_one_manipulability_resolver_serves_runs_in_two_threads_at_once(planar3):
    """The manipulability keeps what it reuses (an SVD object, the kinematics its central difference moves, the model
    its closed-form curvature checked) per thread, so two runs sharing one resolver in two threads give, bit for
    bit, what each gives alone."""
    from concurrent.futures import ThreadPoolExecutor

    resolver = torqueopt.get_resolver("gradient-projection", criterion="manipulability")
    movements = [
        (torqueopt.StraightLine((1.0, 1.0), duration=0.6), PAPER_Q0),
        (torqueopt.StraightLine((-1.0, 0.5), duration=0.6), (0.3, 1.2, -1.0)),
    ]
    alone = [torqueopt.simulate(planar3, resolver, line, q0) for line, q0 in movements]
    interval = sys.getswitchinterval()
    sys.setswitchinterval(1e-6)  # the threads take turns every few bytecodes, inside the curvature
    try:
        with ThreadPoolExecutor(max_workers=2) as pool:
            together = list(pool.map(lambda movement: torqueopt.simulate(planar3, resolver, *movement), movements))
    finally:
        sys.setswitchinterval(interval)
    for one, other in zip(alone, together):
        np.testing.assert_array_equal(one.q, other.q)
        np.testing.assert_array_equal(one.tau, other.tau)
