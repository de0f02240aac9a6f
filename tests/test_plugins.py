"""A user's own resolver: registered by decorator or entry point, named by module:Class, run from the CLI, and
held to the contract by torqueopt.testing.check_resolver, which fails on resolvers broken on purpose."""

import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import torqueopt
from torqueopt.cli import main
from torqueopt.errors import InvalidInput, ResolverNotFound
from torqueopt.resolvers import RESOLVERS, NullSpaceTorque, register_resolver
from torqueopt.resolvers.registry import ResolverRegistry
from torqueopt.resolvers.velocity import VelocityPseudoInverse
from torqueopt.testing import ContractViolation, check_resolver

from .plugin_pkg.resolvers import SelfMotionBrake

ROOT = Path(__file__).resolve().parents[1]
PAPER = ["--robot", "planar3", "--q0=-0.7853981634,2.3561944902,-2.3561944902", "--direction", "1,1"]
BRAKE = "tests.plugin_pkg.resolvers:SelfMotionBrake"


# -- resolvers broken on purpose -----------------------------------------------------------------------------------


class SignFlippedNullSpace(NullSpaceTorque):
    """null-space with the sign of its null-space coordinates flipped: y = −y*, the wrong side of Eq. (31)."""

    def null_space_function(self, robot):
        correct = super().null_space_function(robot)
        return lambda terms, basis, particular: -correct(terms, basis, particular)

    def stack_null_space_function(self, robot):
        correct = super().stack_null_space_function(robot)
        return lambda terms, basis, particular: -correct(terms, basis, particular)


class IgnoredGain(SelfMotionBrake):
    """The brake with its gain option ignored: the step always brakes at 4 1/s."""

    def null_space_function(self, robot):
        def coordinates(terms, null_space_basis, particular):
            return -4.0 * null_space_basis.T @ terms.joint_velocity

        return coordinates

    def objective_function(self, robot):
        return SelfMotionBrake(gain=4.0).objective_function(robot)


class StackDisagrees(SelfMotionBrake):
    """The brake whose step on stacks brakes twice as hard as its single-state step."""

    def null_space_function(self, robot):  # defined beside the stacked one, so the stacks use that one
        return super().null_space_function(robot)

    def stack_null_space_function(self, robot):
        gain = 2 * self.gain
        return lambda terms, basis, particular: -gain * np.einsum("bji,bj->bi", basis, terms.joint_velocity)


class OvershootingRates(VelocityPseudoInverse):
    """velocity-pinv whose rates overshoot the task by 10 % of ‖ẋ‖ (so not affine in ẋ either)."""

    def rate_function(self, robot, task):
        correct = super().rate_function(robot, task)

        def rates(kinematics, task_velocity):
            joint_rates, inverse_condition = correct(kinematics, task_velocity)
            return joint_rates * (1 + 0.1 * np.linalg.norm(task_velocity)), inverse_condition

        return rates

    def step_functions(self, robot, task):
        return self.rate_function(robot, task), None


def test_check_resolver_passes_a_correct_plug_in(planar3, panda):
    for robot in (planar3, panda):
        report = check_resolver(SelfMotionBrake(), robot)
        assert report.checks == ("declaration", "task", "objective", "batch", "options")
        assert report.options == ("gain=8",) and report.unchecked == ()


def test_check_resolver_fails_on_a_flipped_null_space_sign(planar3):
    """Flipping y keeps the task exact (Eq. (26) holds for any y), so only the criterion's optimality, checked by
    finite differences of Eq. (29), catches it."""
    with pytest.raises(ContractViolation) as failure:
        check_resolver(SignFlippedNullSpace(), planar3)
    lines = str(failure.value).splitlines()
    assert lines[0] == "resolver 'null-space' on robot 'planar3' (task xy) breaks its contract:"
    assert lines[1:] and all(line.startswith("objective: state ") for line in lines[1:])
    assert "the minimum of its criterion lies" in lines[1]
    check_resolver("null-space", planar3)  # the unbroken one passes


def test_check_resolver_fails_on_an_ignored_option(planar3):
    with pytest.raises(ContractViolation) as failure:
        check_resolver(IgnoredGain(), planar3)
    assert str(failure.value).splitlines()[1:] == [
        "options: gain=8 changed no torque at 6 states (from 4): the step ignores it"
    ]


def test_check_resolver_fails_on_rates_that_miss_the_task(planar3):
    with pytest.raises(ContractViolation) as failure:
        check_resolver(OvershootingRates(), planar3)
    lines = str(failure.value).splitlines()[1:]
    assert lines[0].startswith("rates: state 0: J q̇ = [") and ", not the commanded ẋ = [" in lines[0]
    assert any("the rates are not affine in ẋ" in line for line in lines)
    assert {line.split(":")[0] for line in lines} == {"rates"}
    check_resolver("velocity-pinv", planar3, options={"self_motion": [0.3, 0.3, 0.3]})


def test_check_resolver_fails_where_stacks_differ_from_single_steps(planar3):
    with pytest.raises(ContractViolation, match=r"\nbatch: state 0: torque \[") as failure:
        check_resolver(StackDisagrees(), planar3)
    assert {line.split(":")[0] for line in str(failure.value).splitlines()[1:]} == {"batch"}


def test_check_resolver_fails_on_a_class_the_workers_cannot_make(planar3):
    class Local(SelfMotionBrake):
        name = "local-brake"

    with pytest.raises(
        ContractViolation,
        match="declaration: its spec 'tests.test_plugins:.*Local' does not make it again .*; define the class at module level",
    ):
        check_resolver(Local(), planar3)


# -- registration by decorator ---------------------------------------------------------------------------------------


@pytest.fixture
def registry():
    """The registry as it is, put back after the test (registration is global state)."""
    saved = (dict(RESOLVERS._classes), dict(RESOLVERS._failures), RESOLVERS._entry_points_loaded)
    yield RESOLVERS
    RESOLVERS._classes, RESOLVERS._failures, RESOLVERS._entry_points_loaded = dict(saved[0]), saved[1], saved[2]


def brake_class(class_name: str, **attributes) -> type:
    """A subclass of the brake made here (its module this file's), with ``attributes``."""
    return type(class_name, (SelfMotionBrake,), {"__module__": __name__, **attributes})


def test_the_decorator_registers_under_the_class_name_or_the_given_one(registry, planar3):
    brake = register_resolver(brake_class("Brake", name="brake"))
    named = register_resolver("brake-by-name")(brake_class("Named"))
    assert list(registry)[-2:] == ["brake", "brake-by-name"] and named.name == "brake-by-name"
    assert torqueopt.resolver_names()[:4] == ["pinv", "inertia-pinv", "null-space", "weighted-null-space"]
    resolver = torqueopt.get_resolver("brake[gain=2]")
    assert type(resolver) is brake and resolver.gain == 2.0 and resolver.label == "brake[gain=2]"
    assert register_resolver(brake) is brake  # the same class again (a module imported twice) is no clash


def test_the_decorator_refuses_in_one_line(registry):
    cases = [
        (lambda: register_resolver("null-space")(brake_class("Other")),
         "resolver name 'null-space' of class tests.test_plugins:Other is taken by "
         "torqueopt.resolvers.null_space:NullSpaceTorque; choose another name"),
        (lambda: register_resolver("a:b")(brake_class("Colon")),
         "resolver name 'a:b' of class tests.test_plugins:Colon is not a name: use letters, digits and -_.+ "
         "(no ':', '[', ',', '=' or spaces), e.g. my-resolver"),
        (lambda: register_resolver(dict), "register_resolver: <class 'dict'> is not a subclass of torqueopt.Resolver"),
        (lambda: register_resolver("x")(brake_class("Says", name="y")),
         "register_resolver('x'): class tests.test_plugins:Says says name = 'y'; give one name"),
    ]  # fmt: skip
    for register, message in cases:
        with pytest.raises(InvalidInput) as error:
            register()
        assert str(error.value) == message


# -- module:Class ------------------------------------------------------------------------------------------------------


def test_an_import_path_makes_the_class_with_its_options(planar3):
    resolver = torqueopt.get_resolver(BRAKE + "[gain=2.5]")
    assert type(resolver) is SelfMotionBrake and resolver.gain == 2.5
    assert resolver.spec == BRAKE + "[gain=2.5]" and resolver.label == "self-motion-brake[gain=2.5]"
    assert "self-motion-brake" not in RESOLVERS  # made, not registered
    assert torqueopt.resolvers.resolver_from_label(resolver.spec).settings == resolver.settings
    assert torqueopt.get_resolver("pinv").spec == "pinv"


@pytest.mark.parametrize(
    "spec, message",
    [
        ("nopackage.nomodule:Thing", "resolver 'nopackage.nomodule:Thing': module 'nopackage.nomodule' does not import "
         "(ModuleNotFoundError: No module named 'nopackage')"),
        ("tests.plugin_pkg.resolvers:Missing", "resolver 'tests.plugin_pkg.resolvers:Missing': module "
         "'tests.plugin_pkg.resolvers' has no 'Missing'"),
        ("tests.plugin_pkg.resolvers:number", "resolver 'tests.plugin_pkg.resolvers:number': number is not a subclass "
         "of torqueopt.Resolver"),
        ("torqueopt.resolvers.base:NullSpaceResolver", "resolver 'torqueopt.resolvers.base:NullSpaceResolver': "
         "NullSpaceResolver leaves null_space_function abstract"),
    ],
)  # fmt: skip
def test_a_bad_import_path_is_one_line_from_the_cli(spec, message, capsys):
    with pytest.raises(ResolverNotFound) as error:
        torqueopt.get_resolver(spec)
    assert str(error.value) == message
    assert main(["run", *PAPER, "--duration", "0.05", "--resolver", spec]) == 2
    assert capsys.readouterr().err == f"torqueopt run: error: {message}\n"


def test_options_in_brackets_and_option_flags_meet_once(capsys):
    code = main(["run", *PAPER, "--duration", "0.05", "--resolver", BRAKE + "[gain=2]", "--option", "gain=3"])
    assert code == 2
    assert capsys.readouterr().err == (
        "torqueopt run: error: --option gain is given twice (in --resolver's brackets or --option); give it once\n"
    )
    with pytest.raises(InvalidInput, match=r"^resolver 'damped-null-space\[damping=2\]' gives option damping again"):
        torqueopt.get_resolver("damped-null-space[damping=2]", damping=3)


def test_an_import_path_runs_from_the_cli_as_the_built_in_law(tmp_path, capsys):
    """The brake at gain k is self-motion-damping at damping k: the two runs agree to round-off."""
    plug_in, built_in = tmp_path / "plug.npz", tmp_path / "built.npz"
    assert (
        main(["run", *PAPER, "--duration", "0.4", "--resolver", BRAKE, "--option", "gain=3", "--out", str(plug_in)])
        == 0
    )
    assert main(["run", *PAPER, "--duration", "0.4", "--resolver", "self-motion-damping[damping=3]",
                 "--out", str(built_in)]) == 0  # fmt: skip
    assert "planar3: resolver self-motion-brake, task xy" in capsys.readouterr().out
    ours, theirs = torqueopt.load_result(plug_in), torqueopt.load_result(built_in)
    assert ours.resolver == "self-motion-brake" and len(ours.t) == len(theirs.t) == 401
    np.testing.assert_allclose(ours.tau, theirs.tau, rtol=1e-12, atol=1e-12)


# -- entry points ------------------------------------------------------------------------------------------------------


def write_distribution(folder: Path, entry_points: dict[str, str]) -> Path:
    """A dist-info as pip would install it: METADATA and entry_points.txt of the group torqueopt.resolvers."""
    info = folder / "torqueopt_brake-0.1.dist-info"
    info.mkdir(parents=True)
    (info / "METADATA").write_text("Metadata-Version: 2.1\nName: torqueopt-brake\nVersion: 0.1\n")
    lines = "".join(f"{name} = {value}\n" for name, value in entry_points.items())
    (info / "entry_points.txt").write_text(f"[torqueopt.resolvers]\n{lines}")
    return folder


def test_an_entry_point_registers_at_the_first_look_up(tmp_path, monkeypatch, planar3):
    site = write_distribution(tmp_path, {"self-motion-brake": BRAKE, "broken": "tests.plugin_pkg.nothing:Broken"})
    monkeypatch.syspath_prepend(str(site))
    registry = ResolverRegistry()  # a registry that has not looked yet
    assert registry._classes == {} and not registry._entry_points_loaded
    assert registry.lookup("self-motion-brake") is SelfMotionBrake
    assert registry.failures == {
        "broken": "entry point 'broken = tests.plugin_pkg.nothing:Broken' of group torqueopt.resolvers "
        "(distribution torqueopt-brake 0.1) failed to load: ModuleNotFoundError: No module named "
        "'tests.plugin_pkg.nothing'"
    }
    with pytest.raises(ResolverNotFound) as error:
        registry.lookup("broken")
    assert str(error.value) == f"resolver 'broken': {registry.failures['broken']}"
    check_resolver(registry.lookup("self-motion-brake")(), planar3)


def test_an_entry_point_whose_class_says_another_name_fails_to_load(tmp_path, monkeypatch):
    monkeypatch.syspath_prepend(str(write_distribution(tmp_path, {"brake": BRAKE})))
    registry = ResolverRegistry()
    assert list(registry) == []
    assert registry.failures["brake"].endswith(
        "failed to load: InvalidInput: its class says name = 'self-motion-brake'; make the two names equal"
    )


def test_an_entry_point_runs_from_the_cli_and_is_listed(tmp_path):
    """A fresh process, as a user's: the entry point of an installed distribution, by name, on the command line."""
    site = write_distribution(
        tmp_path / "site", {"self-motion-brake": BRAKE, "broken": "tests.plugin_pkg.nothing:Broken"}
    )
    environment = {**os.environ, "PYTHONPATH": os.pathsep.join([str(ROOT), str(site)])}
    out = tmp_path / "brake.npz"

    def torqueopt_cli(*arguments):
        return subprocess.run([sys.executable, "-m", "torqueopt", *arguments], capture_output=True, text=True,
                              cwd=tmp_path, env=environment)  # fmt: skip

    listed = torqueopt_cli("resolvers")
    assert listed.returncode == 0
    assert (
        "\nself-motion-brake: Brakes the self-motion: y = −k Zᵀq̇, the least ‖(I − J⁺J)(q̈ + k q̇)‖².\n" in listed.stdout
    )
    assert "    gain [1/s]: number >= 0, default 4\n" in listed.stdout
    assert listed.stdout.endswith(
        "plug-ins that failed to load:\n    broken: entry point 'broken = tests.plugin_pkg.nothing:Broken' of group "
        "torqueopt.resolvers (distribution torqueopt-brake 0.1) failed to load: ModuleNotFoundError: No module named "
        "'tests.plugin_pkg.nothing'\n"
    )
    broken = torqueopt_cli("run", *PAPER, "--duration", "0.2", "--resolver", "broken")
    assert broken.returncode == 2 and broken.stderr == (
        "torqueopt run: error: resolver 'broken': entry point 'broken = tests.plugin_pkg.nothing:Broken' of group "
        "torqueopt.resolvers (distribution torqueopt-brake 0.1) failed to load: ModuleNotFoundError: No module named "
        "'tests.plugin_pkg.nothing'\n"
    )
    imported = subprocess.run(
        [sys.executable, "-c", "import sys, torqueopt, torqueopt.atlas; "
         "print(torqueopt.resolvers.RESOLVERS._entry_points_loaded, 'tests.plugin_pkg.resolvers' in sys.modules)"],
        capture_output=True, text=True, cwd=tmp_path, env=environment,
    )  # fmt: skip
    assert imported.stdout == "False False\n"  # importing torqueopt loads no plug-in
    run = torqueopt_cli(
        "run", *PAPER, "--duration", "0.2", "--resolver", "self-motion-brake[gain=3]", "--out", str(out)
    )
    assert run.returncode == 0 and run.stderr == ""
    built_in = tmp_path / "built.npz"
    assert main(["run", *PAPER, "--duration", "0.2", "--resolver", "self-motion-damping[damping=3]",
                 "--out", str(built_in)]) == 0  # fmt: skip
    np.testing.assert_allclose(torqueopt.load_result(out).tau, torqueopt.load_result(built_in).tau, atol=1e-12)


def test_an_option_of_a_plug_in_is_checked_by_its_declaration():
    with pytest.raises(InvalidInput) as error:
        torqueopt.get_resolver(BRAKE + "[gain=-1]")
    assert str(error.value) == "option gain=-1 of resolver 'self-motion-brake' must be a finite number >= 0 [1/s]"


@pytest.mark.slow
def test_an_entry_point_runs_in_a_two_worker_atlas(tmp_path):
    """The plug-in by its entry-point name in an atlas on 2 Dask workers (separate processes, which import it),
    row by row equal to the built-in law it restates, self-motion-damping at the same rate, in the same atlas."""
    pandas = pytest.importorskip("pandas")
    pytest.importorskip("pyarrow")
    pytest.importorskip("distributed")
    site = write_distribution(tmp_path / "site", {"self-motion-brake": BRAKE})
    environment = {**os.environ, "PYTHONPATH": os.pathsep.join([str(ROOT), str(site)])}
    out = tmp_path / "atlas"
    process = subprocess.run(
        [sys.executable, "-m", "torqueopt", "atlas", "--robot", "planar3", "--paths", "4", "--durations", "0.5",
         "--workers", "2", "--chunk-size", "2", "--no-figures", "--no-progress", "--out", str(out),
         "--resolvers", "pinv,self-motion-damping[damping=3],self-motion-brake[gain=3]"],
        capture_output=True, text=True, cwd=tmp_path, env=environment, timeout=600,
    )  # fmt: skip
    assert process.returncode == 0, process.stderr
    table = pandas.read_parquet(out / "results.parquet")
    brake = table[table["resolver"] == "self-motion-brake[gain=3]"].sort_values("path").reset_index(drop=True)
    damping = table[table["resolver"] == "self-motion-damping[damping=3]"].sort_values("path").reset_index(drop=True)
    assert len(brake) == len(damping) == 4
    numbers = [column for column in brake.columns if pandas.api.types.is_float_dtype(brake[column])]
    assert "peak_torque_ratio" in numbers
    np.testing.assert_allclose(brake[numbers].to_numpy(), damping[numbers].to_numpy(), rtol=1e-9, atol=1e-12)
