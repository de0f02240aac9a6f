"""The resolver contract, checked for every registered resolver at seeded random
states on the planar arm and on 7-DOF arms:

* torqueopt.testing.check_resolver, the suite users run on their own: the torque
  realises the task (with q̈ = ABA(q, q̇, τ) computed by Pinocchio from the torque
  alone, J q̈ + J̇q̇ = ẍ up to what it reports as given up), the declared criterion's
  optimum by finite differences, stacks against single steps, options that act;
* each resolver is the optimum of its own criterion, checked against the
  paper's closed formulas (Eq. (16), Eq. (31), Eq. (33)), computed independently with
  numpy's pseudoinverse truncated to the known rank, and against the
  first-order optimality conditions.
"""

import numpy as np
import pinocchio as pin
import pytest

import torqueopt
from torqueopt.errors import NoRedundancy, SingularJacobian
from torqueopt.resolvers.null_space import torque_midpoint
from torqueopt.testing import check_resolver

ROBOTS = ["planar3", "panda", "panda_pose", "xarm7"]
PAPER_RESOLVERS = ["pinv", "inertia-pinv", "null-space", "weighted-null-space"]


def random_cases(robot, rng, count=6):
    # Pinocchio's randomConfiguration draws from a global C++ generator: seed it from the test's rng.
    pin.seed(int(rng.integers(2**31)))
    for _ in range(count):
        q = pin.randomConfiguration(robot.model) if robot.nv > 3 else rng.uniform(-np.pi, np.pi, 3)
        v = rng.uniform(-1.5, 1.5, robot.nv)
        xdd = rng.uniform(-2.0, 2.0, robot.m)
        terms = robot.terms(q, v)
        if np.linalg.svd(terms.jacobian, compute_uv=False)[-1] < 1e-3:
            continue
        yield q, v, xdd, terms


def truncated_pinv(matrix, rank):
    """Moore-Penrose pseudoinverse keeping exactly ``rank`` singular values."""
    u, s, vt = np.linalg.svd(matrix)
    return (vt[:rank].T / s[:rank]).dot(u[:, :rank].T)


def paper_torque(robot, name, terms, xdd):
    """τ from the paper's formulas, Eq. (34), Eq. (35), Eq. (36), Eq. (37), written literally."""
    H, b, J = terms.inertia, terms.bias_torque, terms.jacobian
    n, m = robot.nv, robot.m
    J_pinv = truncated_pinv(J, m)
    pseudo = J_pinv.dot(xdd - terms.drift)
    tau_tilde = H.dot(pseudo) + b  # Eq. (28)
    if name == "pinv":
        return tau_tilde  # Eq. (34)
    if name == "inertia-pinv":
        H_inv = np.linalg.inv(H)
        J_H = H_inv.dot(J.T).dot(np.linalg.inv(J.dot(H_inv).dot(J.T)))  # Eq. (16) with W = H
        return H.dot(J_H.dot(xdd - terms.drift)) + b  # Eq. (35)
    projector = np.eye(n) - J_pinv.dot(J)
    tau_hat_mid = torque_midpoint(robot) - tau_tilde  # (τ̂⁺ + τ̂⁻)/2
    if name == "null-space":
        phi = truncated_pinv(H.dot(projector), n - m).dot(tau_hat_mid)  # Eq. (31)
    else:
        root = np.diag(np.sqrt(default_weight(robot)))
        phi = truncated_pinv(root.dot(H).dot(projector), n - m).dot(root.dot(tau_hat_mid))  # Eq. (33)
    return tau_tilde + H.dot(projector).dot(phi)  # Eq. (27)


def default_weight(robot):
    torque_range = robot.torque_upper - robot.torque_lower
    return np.where(np.isfinite(torque_range), 1.0 / torque_range**2, 0.0)


#: What check_resolver's options check sets per resolver, where its default choice (twice a number, another named
#: choice) says nothing: None leaves out an option that only matters in situations random states do not reach.
CONTRACT_OPTIONS = {
    "bounded-torque": {"joint_acceleration_limit": 0.5, "infeasible": None, "joint_limits": None},
    "minmax-torque": {"joint_acceleration_limit": 0.5, "infeasible": None, "joint_limits": None},
    # energy_rate matters only while the barrier holds the self-motion energy (tested in test_energy_bounded.py)
    "energy-bounded-torque": {"energy_limit": 1e-3, "energy_rate": None, "infeasible": None, "joint_limits": None,
                              "joint_acceleration_limit": None},
    "gradient-projection-acceleration": {"k": 3.0},
    "task-priority-acceleration": {"secondary": None},  # its one other choice, 'posture', is the default's task
}  # fmt: skip


#: The resolvers that declare the criterion they minimise (Resolver.objective_function).
OBJECTIVES = {
    "pinv", "inertia-pinv", "null-space", "weighted-null-space", "damped-null-space", "self-motion-damping",
    "inverse-inertia-torque", "inverse-inertia-squared-torque", "bounded-torque", "energy-bounded-torque",
}  # fmt: skip
#: The resolvers whose steps return the program they solved (Resolver.program_solver), checked by its KKT conditions.
PROGRAMS = {"bounded-torque", "minmax-torque", "energy-bounded-torque"}


@pytest.mark.parametrize("robot_name", ROBOTS)
@pytest.mark.parametrize("name", torqueopt.resolver_names("torque"))
def test_every_resolver_meets_the_contract(name, robot_name, request):
    """torqueopt.testing.check_resolver, as a user runs it on theirs: the torque against Pinocchio's ABA and the
    task, the declared criterion's optimum by finite differences, stacks against single steps, options that act."""
    if name == "receding-horizon":
        pytest.skip("an NLP per state and option: its contract runs on a short horizon in test_receding_horizon.py")
    robot = request.getfixturevalue(robot_name)
    options = dict(CONTRACT_OPTIONS.get(name, {}))
    if name == "weighted-null-space":
        options["weight"] = np.linspace(1.0, 3.0, robot.nv)
    report = check_resolver(name, robot, options=options)
    declares, programs = name in OBJECTIVES, name in PROGRAMS
    assert report.checks == (
        "declaration", "task", *(("program",) if programs else ()), *(("objective",) if declares else ()), "batch",
        "options",
    )  # fmt: skip
    assert len(report.options) == len(torqueopt.resolvers.RESOLVERS[name].options) - sum(
        value is None for value in options.values()
    )


#: The same for the velocity-level resolvers, on joint_rates (position_gain acts in closed loop only, so
#: check_resolver leaves it out there).
VELOCITY_CONTRACT_OPTIONS = {
    "velocity-pinv": {"self_motion": 0.3},  # a vector of n such values, made per robot below
    "gradient-projection": {"k": 3.0},
    "task-priority": {"secondary": None},  # its one named choice, 'posture', is the default's task
    "extended-jacobian": {"algorithmic_tolerance": None},  # acts only where the augmented Jacobian degenerates
    "obstacle-avoidance": {"influence": None, "critical": None},  # act only near the obstacle
}


@pytest.mark.parametrize("robot_name", ["planar3", "panda"])
@pytest.mark.parametrize("name", torqueopt.resolver_names("velocity"))
def test_every_velocity_level_resolver_meets_the_contract(name, robot_name, request):
    """check_resolver on joint_rates: J q̇ = ẋ, rates affine in ẋ, options that act, the spec that travels."""
    robot = request.getfixturevalue(robot_name)
    resolver = torqueopt.get_resolver(name, **({"obstacle": "1.2,0.3,0.0,0.1"} if name == "obstacle-avoidance" else {}))
    try:
        resolver.check(robot)
    except NoRedundancy as error:  # extended-jacobian needs n − m = 1
        pytest.skip(str(error))
    options = dict(VELOCITY_CONTRACT_OPTIONS.get(name, {}))
    if "self_motion" in options:
        options["self_motion"] = np.full(robot.nv, options["self_motion"])
    report = check_resolver(resolver, robot, options=options)
    assert report.checks == ("declaration", "rates", "options")


def test_obstacle_avoidances_label_writes_the_obstacle_as_its_option_reads_it():
    """An obstacle given as an ObstacleTask: the label writes x,y,z,radius, and get_resolver(label) makes an
    obstacle of the same centre and radius; one with a speed of its own (which the numbers cannot say) keeps its
    repr."""
    from torqueopt.tasks import ObstacleTask

    resolver = torqueopt.get_resolver("obstacle-avoidance", obstacle=ObstacleTask([1 / 3, 0.3], 0.1), influence=0.4)
    assert resolver.label == "obstacle-avoidance[obstacle=0.3333333333333333,0.3,0,0.1,influence=0.4]"
    again = torqueopt.get_resolver(resolver.label)
    assert again.obstacle.center.tolist() == [1 / 3, 0.3, 0.0] and again.obstacle.radius == 0.1
    assert (again.label, again.influence) == (resolver.label, 0.4)
    own_speed = torqueopt.get_resolver("obstacle-avoidance", obstacle=ObstacleTask([1.2, 0.3], 0.1, speed=0.7))
    assert own_speed.label == "obstacle-avoidance[obstacle=ObstacleTask(center=[1.2, 0.3, 0.0], radius=0.1)]"


@pytest.mark.parametrize("robot_name", ROBOTS)
@pytest.mark.parametrize("name", PAPER_RESOLVERS)
def test_every_paper_resolver_matches_the_papers_formula(name, robot_name, request, rng):
    robot = request.getfixturevalue(robot_name)
    resolver = torqueopt.get_resolver(name)
    for q, v, xdd, terms in random_cases(robot, rng):
        torque = resolver.resolve(robot, terms, xdd).torque
        expected = paper_torque(robot, name, terms, xdd)
        np.testing.assert_allclose(torque, expected, rtol=1e-7, atol=1e-7 * (1 + np.abs(expected).max()))


@pytest.mark.parametrize("robot_name", ROBOTS)
def test_null_space_resolvers_are_least_squares_optima(robot_name, request, rng):
    """First-order conditions of Eq. (29) and Eq. (32): the residual τ − τ_mid is
    (W-)orthogonal to every torque change H Z y the null space allows, and no
    random null-space change lowers the cost."""
    robot = request.getfixturevalue(robot_name)
    for name, weight in (("null-space", np.ones(robot.nv)), ("weighted-null-space", default_weight(robot))):
        resolver = torqueopt.get_resolver(name)
        for q, v, xdd, terms in random_cases(robot, rng, count=4):
            torque = resolver.resolve(robot, terms, xdd).torque
            null_basis = np.linalg.svd(terms.jacobian)[2][robot.m :].T
            allowed = terms.inertia.dot(null_basis)
            residual = weight * (torque - torque_midpoint(robot))
            scale = np.linalg.norm(allowed) * np.linalg.norm(residual) + 1e-12
            assert np.abs(allowed.T.dot(residual)).max() < 1e-9 * scale

            def cost(tau):
                error = tau - torque_midpoint(robot)
                return float(error.dot(weight * error))

            best = cost(torque)
            for _ in range(20):
                assert cost(torque + allowed.dot(rng.normal(size=robot.redundancy) * 0.1)) >= best - 1e-12 * (1 + best)


@pytest.mark.parametrize("robot_name", ROBOTS)
def test_pseudoinverses_minimise_their_acceleration_norms(robot_name, request, rng):
    robot = request.getfixturevalue(robot_name)
    for q, v, xdd, terms in random_cases(robot, rng, count=4):
        null_basis = np.linalg.svd(terms.jacobian)[2][robot.m :].T
        plain = torqueopt.get_resolver("pinv").resolve(robot, terms, xdd).joint_acceleration
        weighted = torqueopt.get_resolver("inertia-pinv").resolve(robot, terms, xdd).joint_acceleration
        assert np.abs(null_basis.T.dot(plain)).max() < 1e-10 * (1 + np.abs(plain).max())  # min ‖q̈‖²
        assert np.abs(null_basis.T.dot(terms.inertia.dot(weighted))).max() < 1e-9 * (
            1 + np.abs(weighted).max()
        )  # min q̈ᵀHq̈


def test_loose_pseudoinverse_cutoff_would_be_wrong_where_ours_is_right(planar3):
    """H(I − J⁺J) has rank n − m = 1; a pseudoinverse that keeps its round-off
    singular value (the pitfall) projects onto two directions instead of one
    and gives a plausible-looking but wrong torque. The resolver matches the
    form truncated to the known rank."""
    q, v = np.array([0.4, 1.2, -0.9]), np.array([0.3, -0.2, 0.5])
    terms = planar3.terms(q, v)
    xdd = np.array([1.0, 1.0])
    tau = torqueopt.get_resolver("null-space").resolve(planar3, terms, xdd).torque
    np.testing.assert_allclose(tau, paper_torque(planar3, "null-space", terms, xdd), atol=1e-9)

    J_pinv = np.linalg.pinv(terms.jacobian)
    product = terms.inertia.dot(np.eye(3) - J_pinv.dot(terms.jacobian))
    singular_values = np.linalg.svd(product, compute_uv=False)
    assert 0 < singular_values[1] < 1e-12 * singular_values[0]  # round-off, not zero
    tau_tilde = terms.inertia.dot(J_pinv.dot(xdd - terms.drift)) + terms.bias_torque
    loose = tau_tilde + product.dot(np.linalg.pinv(product, rcond=1e-20).dot(-tau_tilde))
    assert np.abs(loose - tau).max() > 1e-3 * np.abs(tau).max()


def test_weighted_resolver_accepts_a_user_weight(planar3):
    q, v, xdd = np.array([0.4, 1.2, -0.9]), np.zeros(3), np.array([1.0, -0.5])
    terms = planar3.terms(q, v)
    unit = torqueopt.get_resolver("weighted-null-space", weight=np.ones(3)).resolve(planar3, terms, xdd).torque
    plain = torqueopt.get_resolver("null-space").resolve(planar3, terms, xdd).torque
    np.testing.assert_allclose(unit, plain, atol=1e-10)
    matrix = torqueopt.get_resolver("weighted-null-space", weight=np.diag([1.0, 4.0, 9.0]))
    vector = torqueopt.get_resolver("weighted-null-space", weight=[1.0, 4.0, 9.0])
    np.testing.assert_allclose(
        matrix.resolve(planar3, terms, xdd).torque, vector.resolve(planar3, terms, xdd).torque, atol=1e-10
    )


def test_resolve_api_matches_resolver_object(planar3):
    q, v, xdd = np.array([0.4, 1.2, -0.9]), np.array([0.1, 0.2, 0.3]), np.array([1.0, -0.5])
    for name in torqueopt.resolver_names("torque"):
        expected = torqueopt.get_resolver(name).resolve(planar3, planar3.terms(q, v), xdd)
        got = torqueopt.resolve(planar3, name, q, v, xdd)
        np.testing.assert_allclose(got.torque, expected.torque)
        assert (got.task_error, got.infeasible) == (expected.task_error, expected.infeasible)
    weighted = torqueopt.resolve(planar3, "weighted-null-space", q, v, xdd, weight=[1.0, 4.0, 9.0])
    expected = torqueopt.get_resolver("weighted-null-space", weight=[1.0, 4.0, 9.0]).resolve(
        planar3, planar3.terms(q, v), xdd
    )
    np.testing.assert_allclose(weighted.torque, expected.torque)


def test_unknown_option_is_one_line_naming_the_close_match_and_the_valid_ones(planar3):
    with pytest.raises(torqueopt.InvalidInput) as error:
        torqueopt.get_resolver("weighted-null-space", wieght=[1, 1, 1])
    assert str(error.value) == (
        "unknown option 'wieght' for resolver 'weighted-null-space' (did you mean 'weight'?); "
        "valid options: weight, singular_tolerance"
    )
    with pytest.raises(torqueopt.InvalidInput) as error:
        torqueopt.resolve(planar3, "pinv", np.zeros(3) + 0.5, np.zeros(3), [1.0, 0.0], damping=2.0)
    assert str(error.value) == "unknown option 'damping' for resolver 'pinv'; valid options: singular_tolerance"
    with pytest.raises(torqueopt.InvalidInput, match="^unknown option 'weigth' for resolver 'weighted-null-space'"):
        torqueopt.simulate(planar3, "weighted-null-space", torqueopt.StraightLine([1, 1]), [0.4, 1.2, -0.9],
                           resolver_options={"weigth": [1, 1, 1]})  # fmt: skip


def test_bad_option_values_name_the_value_and_what_it_must_be():
    cases = [
        ({"singular_tolerance": 0}, "option singular_tolerance=0 of resolver 'pinv' must be a finite number > 0"),
        (
            {"singular_tolerance": "abc"},
            "option singular_tolerance=abc of resolver 'pinv' is not a number; give a finite number > 0",
        ),
        (
            {"singular_tolerance": float("nan")},
            "option singular_tolerance=nan of resolver 'pinv' must be a finite number > 0",
        ),
    ]
    for options, message in cases:
        with pytest.raises(torqueopt.InvalidInput) as error:
            torqueopt.get_resolver("pinv", **options)
        assert str(error.value) == message
    with pytest.raises(torqueopt.InvalidInput) as error:
        torqueopt.get_resolver("weighted-null-space", weight="1,x,1")
    assert str(error.value) == (
        "option weight=1,x,1 of resolver 'weighted-null-space' is not a vector or a matrix; "
        "give comma-separated numbers, e.g. 1,1,1 [1/(N·m)²]"
    )
    with pytest.raises(torqueopt.InvalidInput) as error:
        torqueopt.get_resolver(torqueopt.get_resolver("pinv"), singular_tolerance=1e-3)
    assert str(error.value) == (
        "options singular_tolerance given with a PseudoInverse object; set them when making it, "
        "or give the resolver's name 'pinv'"
    )


def test_a_misspelt_resolver_name_suggests_the_close_one():
    with pytest.raises(torqueopt.ResolverNotFound) as error:
        torqueopt.get_resolver("null_space")
    assert str(error.value).startswith(
        "unknown resolver 'null_space' (did you mean 'null-space'?): choose one of pinv,"
    )


@pytest.mark.parametrize("name", PAPER_RESOLVERS)
def test_singular_jacobian_is_reported_not_hidden(name, planar3):
    """Straight arm: J has rank 1, no joint acceleration moves the tip along the arm."""
    resolver = torqueopt.get_resolver(name)
    for q in (np.zeros(3), np.array([0.0, 1e-9, -1e-9])):
        with pytest.raises(SingularJacobian, match="task Jacobian is singular"):
            resolver.resolve(planar3, planar3.terms(q, np.zeros(3)), np.array([1.0, 0.0]))


def test_null_space_resolvers_need_redundancy(panda):
    square = torqueopt.load_robot("panda", task="pose", lock=["panda_joint7"])  # m = 6 = n
    for name in ("null-space", "weighted-null-space"):
        with pytest.raises(NoRedundancy, match=r"needs redundancy but task 'pose' \(m=6\) on robot 'panda' \(n=6\)"):
            torqueopt.get_resolver(name).check(square)
    torqueopt.get_resolver("pinv").check(square)
    too_many = torqueopt.load_robot("planar3", task="pose")
    with pytest.raises(NoRedundancy, match="m=6 coordinates but robot 'planar3' moves it with only n=3 joints"):
        torqueopt.get_resolver("pinv").check(too_many)


def test_unknown_resolver_lists_the_registered_names():
    with pytest.raises(torqueopt.ResolverNotFound) as error:
        torqueopt.get_resolver("quadratic")
    assert str(error.value) == f"unknown resolver 'quadratic': choose one of {', '.join(torqueopt.resolver_names())}"


def test_a_user_resolver_plugs_in_through_null_space_function(planar3):
    """A resolver object works wherever a name does; this one damps the
    self-motion velocity, y = −k Zᵀq̇, and still realises the task exactly."""

    class DampedSelfMotion(torqueopt.NullSpaceResolver):
        name = "damped-self-motion"

        def null_space_function(self, robot):
            def coordinates(terms, null_space_basis, particular):
                return -5.0 * null_space_basis.T.dot(terms.joint_velocity)

            return coordinates

    q, v = np.array([0.4, 1.2, -0.9]), np.array([0.3, -0.2, 0.5])
    terms = planar3.terms(q, v)
    resolution = DampedSelfMotion().resolve(planar3, terms, np.array([1.0, -0.5]))
    acceleration = pin.aba(planar3.model, planar3.model.createData(), q, v, resolution.torque)
    np.testing.assert_allclose(terms.jacobian.dot(acceleration) + terms.drift, [1.0, -0.5], atol=1e-10)
    null_basis = np.linalg.svd(terms.jacobian)[2][2:].T
    np.testing.assert_allclose(null_basis.T.dot(acceleration), -5.0 * null_basis.T.dot(v), atol=1e-10)
    result = torqueopt.simulate(planar3, DampedSelfMotion(), torqueopt.StraightLine([1, 1], duration=0.2), q)
    assert result.resolver == "damped-self-motion" and result.completed


@pytest.mark.parametrize(
    "resolver, option, message",
    [
        ("bounded-torque", "kinematic_weight", "option kinematic_weight=1e308 of resolver 'bounded-torque' "
         "must be a number in [0, 1e+06]"),
        ("damped-null-space", "kinematic_weight", "option kinematic_weight=1e308 of resolver 'damped-null-space' "
         "must be a number in [0, 1e+06]"),
        ("task-priority", "damping", "option damping=1e308 of resolver 'task-priority' must be a number in [0, 1e+06]"),
        ("task-priority", "position_gain", "option position_gain=1e308 of resolver 'task-priority' "
         "must be a number in [0, 1e+06] [1/s]"),
    ],
)  # fmt: skip
def test_options_whose_arithmetic_overflows_are_bounded_in_one_line(resolver, option, message, capsys):
    """kinematic_weight=1e308 squared, damping=1e308 squared overflowed (OverflowError); position_gain=1e308 made
    the SVD fail to converge: each is refused where it enters, in one line naming the valid range."""
    from torqueopt.cli import main

    code = main(["run", "--robot", "planar3", "--direction", "1,1", "--duration", "0.05",
                 "--resolver", resolver, "--option", f"{option}=1e308"])  # fmt: skip
    assert code == 2
    assert capsys.readouterr().err == f"torqueopt run: error: {message}\n"
    torqueopt.get_resolver(resolver, **{option: 1e6})  # the bound itself is valid
