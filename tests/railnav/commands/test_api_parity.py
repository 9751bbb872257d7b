"""Every ``railnav`` command is a thin layer over documented public functions, with their
defaults (STYLE.md §2.11; `railnav`'s module docstring lists them).

The commands and their options come from the CLI's own parser (`railnav.cli.build_parser`),
never from a hand list: a new command, or a new option, with no entry in `API` fails
`test_every_command_and_option_is_mapped`. Each option maps to what its value becomes:

* `Param`: a parameter of a public function. The option's default, turned into the API's
  value (`cli`: 1-based -> 0-based, a ``--no-x`` flag negated), must equal the parameter's
  default (`inspect.signature`). A CLI default None against an API default that is not
  None is allowed only with ``none_is_default=True``: the handler leaves the argument out
  (or puts the same owner's constant in) when the flag is not given;
* `Field`: a field of a configuration dataclass the handler builds with the flags given (a
  CLI None: the field's default);
* `Calls`: a flag whose presence calls this public function (a file it reads, a result
  it adds); no default to compare.

For `Param` and `Field`, a number the help text states as the default (``default 16``,
``default: 0.5``) must be the API's too, so that a help literal cannot drift from its
owner. `CLI_ONLY` lists, with the reason, what the command line alone has (where to write,
verbosity). Every function named must be public (in `railnav`'s or its module's
``__all__``) and documented: a docstring that names each mapped parameter or field.

A deliberate difference between a command and its function would go into `DELIBERATE`
with the reason; none remains (stop 38: ``network route --max-routes`` was 3 against
``Network.routes``' 5; ``run_files_tracks``' filter the constrained one against the
command's gnss-only without an IMU; its and ``run_files_network``'s outages ``()``
against ``run_files``' None, the outages of ``railnav simulate``'s files: all now one
rule).
"""
from __future__ import annotations

import argparse
import dataclasses
import importlib
import inspect
import re
from dataclasses import dataclass
from typing import Any, Callable

import pytest

from railnav.cli import build_parser


def _same(v):
    return v


def _negated(v):
    return not v


def _on_or_none(v):
    """A flag that switches on a configuration object (off: None)."""
    return True if v else None


@dataclass(frozen=True)
class Param:
    owner: str                  # "module:qualname" of a public function
    name: str
    cli: Callable[[Any], Any] = _same
    none_is_default: bool = False
    also: tuple[str, ...] = ()  # other functions the value goes to, same name and default


@dataclass(frozen=True)
class Field:
    owner: str                  # "module:qualname" of a dataclass
    name: str
    cli: Callable[[Any], Any] = _same


@dataclass(frozen=True)
class Calls:
    owner: str


RUN, RUN_SIM = "railnav.jobs.run:run_files", "railnav.jobs.run:run_simulated"
NET_FILES, NET_SIM = "railnav.jobs.network:run_files_network", \
    "railnav.jobs.network_sim:run_simulated_route"
#: ``run`` with several tracks, or --network: the same keywords as `run_files`.
MORE = ("railnav.jobs.tracks:run_files_tracks", NET_FILES)
OVERRIDES = "railnav.simulation.scenarios:Scenario.with_overrides"
NAV = "railnav.navigation.network_config:NetworkNavConfig"
FIX_MODEL = "railnav.filters.fix_epochs:FixModelConfig"
ARMS = "railnav.filters.track_frame:LeverArms"
SPP = "railnav.jobs.spp:spp_files"
LOAD_NETWORK = "trackmodel.network_routes:load_network"
ROUTE_LEGS = "trackmodel.network_routes:route_legs"

#: Where every option of ``run`` goes (sensor files: `run_files`; a simulated trip: the
#: scenario and `run_simulated`; several tracks, a network: their jobs).
RUN_OPTIONS = {
    "imu": Param(RUN, "imu_path", also=MORE), "obs": Param(RUN, "obs_path", also=MORE),
    "nav": Param(RUN, "nav_path", also=MORE), "fixes": Param(RUN, "fixes_path", also=MORE),
    "fix_sigma": Param(RUN, "fix_sigmas", also=MORE),
    "fix_track_sigma_m": Field(FIX_MODEL, "track_cross_sigma_m"),
    "no_fix_heights": Field(FIX_MODEL, "use_height", _negated),
    "correlated_fix_errors": Field(FIX_MODEL, "correlated_code_errors"),
    "truth": Param(RUN, "truth_path", also=MORE[1:]),
    "truth_quality": Param(RUN, "truth_quality", also=MORE[1:]),
    "start_gps_time_s": Param(RUN, "start_gps_time_s", also=MORE),
    "scenario": Param("railnav.simulation.scenarios:scenario_for_track", "name"),
    "imu_grade": Param(RUN, "imu_grade", also=MORE),
    "speed_mps": Param(OVERRIDES, "speed_mps"), "duration_s": Param(OVERRIDES, "duration_s"),
    # None: scenario.json's outages beside the files (railnav.jobs.scoring.file_outages)
    "outage": Param(RUN, "outages", also=MORE),
    "filter": Param(RUN, "filter", also=MORE), "systems": Param(RUN, "systems", also=MORE),
    "window": Param(RUN, "window", also=MORE),
    "seed": Param(RUN_SIM, "seed", none_is_default=True,
                  also=("railnav.jobs.tracks:run_simulated_tracks",
                        "railnav.jobs.network:run_simulated_network")),
    # 1-based on the command line ("--true-track 1" is the first track given)
    "true_track": Param("railnav.jobs.tracks:run_simulated_tracks", "true_track",
                        lambda v: (v or 1) - 1),
    "crossing_rate_per_s": Param("railnav.jobs.tracks:track_nav", "crossing_rate_per_s",
                                 none_is_default=True),
    "baro": Calls("railnav.jobs.baro:add_run_baro"),
    "base": Param(RUN, "base_path"), "base_position": Param(RUN, "base_lat_lon_h"),
    "max_age_s": Param(RUN, "max_correction_age_s"), "smooth_window_s": Param(RUN, "smoothing"),
    "sp3": Param(RUN, "sp3_paths"),
    "network": Param(NET_FILES, "network"), "start": Param(NET_FILES, "start"),
    "start_abreast_probability": Field(NAV, "start_abreast_probability"),
    "max_hypotheses": Field(NAV, "max_hypotheses"),
    "fix_correlation_s": Field(NAV, "evidence_correlation_s"),
    "fix_bias_sigma_m": Field(NAV, "fix_bias_sigma_m"),
    "no_spawn": Field(NAV, "spawn", _negated),
    "track_attitude": Param(RUN, "track_attitude", _on_or_none),
    "standstill": Param(RUN, "standstill", _on_or_none),
    "no_recover": Field("railnav.navigation.monitor_config:MonitorConfig", "recover", _negated),
    "suspension_noise": Field("railnav.config:NavigatorConfig", "suspension_noise"),
    "car_body": Field("railnav.simulation.scenarios:Scenario", "car_body", _on_or_none),
    # a flag that switches off what is on by default (absent: the configuration's own)
    "no_noise_scale": Param(RUN, "noise_scale", lambda v: False if v else None),
    "imu_spec": Param(RUN, "imu_spec"), "sigma_pr_m": Param(RUN, "sigma_pr_m"),
    "sigma_rr_mps": Param(RUN, "sigma_rr_mps"), "odometer": Param(RUN, "odometer_path"),
    "wheel_circumference_m": Param(RUN, "wheel_circumference_m"),
    "pulses_per_rev": Param(RUN, "pulses_per_rev"),
    "odometer_sigma_mps": Field("railnav.filters.odometer_epochs:OdometerConfig",
                                "sigma_speed_mps"),
    "balises": Param(RUN, "balises_path"),
    "balise_sigma_m": Field("railnav.filters.balise_epochs:BaliseModelConfig", "sigma_m"),
    "lever_arm": Field(ARMS, "antenna_m"), "imu_lever_arm": Field(ARMS, "imu_m"),
    "balise_reader_forward_m": Field(ARMS, "balise_reader_forward_m"),
    "no_plots": Param("railnav.jobs.run:write_run", "plots", _negated),
    "smooth": Param(RUN, "smooth"),
    "export": Calls("railnav.jobs.export:write_run_exports"),
}

SIM_CONFIGS = "railnav.simulation.track_sensors"
SIMULATE_OPTIONS = {
    "network": Calls(LOAD_NETWORK), "route": Calls(ROUTE_LEGS),
    "scenario": Param("railnav.simulation.scenarios:scenario_for_track", "name"),
    "imu_grade": Param(OVERRIDES, "imu_errors"), "speed_mps": Param(OVERRIDES, "speed_mps"),
    "duration_s": Param(OVERRIDES, "duration_s"), "outage": Param(OVERRIDES, "outages"),
    "gnss": Param("railnav.simulation.trip:simulate_trip", "gnss"),
    "systems": Param("railnav.simulation.trip:simulate_trip", "systems"),
    "seed": Param("railnav.simulation.trip:simulate_trip", "seed"),
    "fixes_format": Calls("railnav.simulation.fixes:trip_fixes"),
    "fixes_rate_hz": Field("railnav.simulation.fixes:FixSimConfig", "rate_hz"),
    "fixes_quality": Field("railnav.simulation.fixes:FixSimConfig", "quality_mix"),
    "odometer": Calls(f"{SIM_CONFIGS}:simulate_odometer"),
    "odometer_kind": Field(f"{SIM_CONFIGS}:OdometerSimConfig", "kind"),
    "odometer_rate_hz": Field(f"{SIM_CONFIGS}:OdometerSimConfig", "rate_hz"),
    "odometer_scale_error": Field(f"{SIM_CONFIGS}:OdometerSimConfig", "scale_error"),
    "slip": Field(f"{SIM_CONFIGS}:OdometerSimConfig", "slips"),
    "balises": Calls(f"{SIM_CONFIGS}:simulate_balises"),
    "balise_spacing_m": Field(f"{SIM_CONFIGS}:BaliseSimConfig", "spacing_m"),
    "baro": Calls(f"{SIM_CONFIGS}:simulate_baro_readings"),
    "baro_bias_m": Field(f"{SIM_CONFIGS}:BaroSimConfig", "bias_m"),
    "imu_jitter_s": Field("railnav.simulation.imu_logs:ImuLogSimConfig", "jitter_s"),
    "imu_dropouts": Field("railnav.simulation.imu_logs:ImuLogSimConfig", "dropouts"),
    "lever_arm": Field("railnav.simulation.scenarios:Scenario", "antenna_m"),
}

TOL = {"tol_m": Param(LOAD_NETWORK, "tol_m")}
IMPORT = "railnav.jobs.network_import:import_network"

#: Command -> (its public functions, where each option goes).
API: dict[tuple[str, ...], tuple[tuple[str, ...], dict]] = {
    ("run",): ((RUN, RUN_SIM, "railnav.jobs.run:write_run",
                "railnav.jobs.tracks:run_files_tracks", "railnav.jobs.tracks:run_simulated_tracks",
                "railnav.jobs.tracks:write_track_run", NET_FILES,
                "railnav.jobs.network:write_network_run"), RUN_OPTIONS),
    ("simulate",): (("railnav.simulation.trip:simulate_trip",
                     "railnav.jobs.simulated_files:write_simulated_trip"), SIMULATE_OPTIONS),
    ("spp",): ((SPP,), {
        "systems": Param(SPP, "systems"), "ionosphere": Param(SPP, "ionosphere"),
        "elevation_mask_deg": Param(SPP, "elevation_mask_deg"), "raim": Param(SPP, "raim"),
        "ref": Param(SPP, "reference"), "base": Param(SPP, "base"),
        "base_position": Param(SPP, "base_position"), "max_age_s": Param(SPP, "max_age_s"),
        "smooth_window_s": Param(SPP, "smooth_window_s"), "sp3": Param(SPP, "sp3")}),
    ("study",): (("railnav.studies.file:load_study_config", "railnav.studies.study:run_study"), {
        "scheduler": Param("railnav.studies.study:run_study", "scheduler"),
        "workers": Param("railnav.studies.study:run_study", "workers"),
        "no_plots": Param("railnav.studies.study:run_study", "plots", _negated)}),
    ("reproduce",): (("railnav.reproduce.common:run_experiment",
                      "railnav.reproduce.common:write_result_json"), {
        "runs": Param("railnav.reproduce.common:run_experiment", "runs"),
        "seed": Param("railnav.reproduce.common:run_experiment", "seed")}),
    ("track", "fit"): (("railnav.jobs.survey:fit_survey",), {
        "leg": Param("railnav.jobs.survey:fit_survey", "leg"),
        "tol_m": Param("railnav.jobs.survey:fit_survey", "tol_m",
                       also=("trackmodel.fit:fit_track",)),
        "vtol_m": Param("railnav.jobs.survey:fit_survey", "vtol_m",
                        also=("trackmodel.fit:fit_track",))}),
    ("track", "sample"): (("trackmodel.summary:sample_track",), {
        "step_m": Param("trackmodel.summary:sample_track", "step_m")}),
    ("track", "info"): (("trackmodel.summary:track_info",), {}),
    ("track", "plot"): (("trackmodel.plot:plot_track",), {}),
    ("network", "import"): ((IMPORT,), {"tol_m": Param(IMPORT, "tol_m",
                                                       also=(LOAD_NETWORK,))}),
    ("network", "build"): ((IMPORT,), {"tol_m": Param(IMPORT, "tol_m",
                                                      also=(LOAD_NETWORK,))}),
    ("network", "check"): (("trackmodel.network_check:check_network",), {
        "tol_m": Param("trackmodel.network_check:check_network", "tol_m")}),
    ("network", "plot"): (("railnav.evaluation.network_map:plot_network_map",), {
        **TOL, "route": Calls(ROUTE_LEGS),
        "fixes": Param("railnav.evaluation.network_map:network_map_figure", "fixes")}),
    ("network", "route"): (("trackmodel.network:Network.routes", ROUTE_LEGS), {
        **TOL, "start": Param("trackmodel.network:Network.routes", "start"),
        "end": Param("trackmodel.network:Network.routes", "end"),
        "elements": Calls(ROUTE_LEGS),
        "max_routes": Param("trackmodel.network:Network.routes", "max_routes",
                            none_is_default=True)}),
    ("network", "info"): ((LOAD_NETWORK,), {}),
    ("network", "routes"): (("railnav.jobs.network:route_candidates",), {
        "horizon_m": Param("railnav.jobs.network:route_candidates", "horizon_m")}),
    ("network", "run"): ((NET_SIM, NET_FILES, "railnav.jobs.network:write_network_run"), {
        "horizon_m": Param(NET_SIM, "horizon_m"),
        "true_route": Param(NET_SIM, "true_route", none_is_default=True),
        "duration_s": Param(NET_SIM, "duration_s"),
        "speed_mps": Param(NET_SIM, "speed_mps", none_is_default=True),
        "seed": Param(NET_SIM, "seed", none_is_default=True),
        "imu": Param(NET_FILES, "imu_path"), "obs": Param(NET_FILES, "obs_path"),
        "nav": Param(NET_FILES, "nav_path"), "max_hypotheses": Field(NAV, "max_hypotheses"),
        "no_plots": Param("railnav.jobs.network:write_network_run", "plots", _negated)}),
}

#: What only the command line has, with the reason (every command).
CLI_ONLY = {
    "help": "argparse", "verbose": "logging (railnav.cli)", "quiet": "logging, progress bars",
    "debug": "tracebacks (railnav.cli)",
    "out": "where to write: a folder railnav-<command> by default (output_directory), or "
           "the file a library writer is given",
    "overwrite": "replacing an existing output (trackmodel.files)",
    "residuals": "track fit: also writes TrackFit.residuals",
    "json": "track info: TrackInfo.to_dict printed as JSON",
    # names the default of the flag beside it, kept for scripts that give it
    "spawn": "--no-spawn's default (NetworkNavConfig.spawn)",
    "recover": "--no-recover's default (MonitorConfig.recover)",
}

#: (command, option) -> why the command's default differs from its function's. Empty.
DELIBERATE: dict[tuple[tuple[str, ...], str], str] = {}


def _commands(parser: argparse.ArgumentParser, path=()):
    """(command path, parser) of every leaf command of `parser`."""
    subs = [a for a in parser._actions if isinstance(a, argparse._SubParsersAction)]
    if not subs:
        yield path, parser
        return
    for name, child in subs[0].choices.items():
        yield from _commands(child, (*path, name))


PARSER = build_parser()
COMMANDS = dict(_commands(PARSER))
OPTIONS = [(path, action) for path, p in COMMANDS.items() for action in p._actions
           if action.option_strings and action.dest not in CLI_ONLY and not action.required]


def _resolve(owner: str):
    module, _, qualname = owner.partition(":")
    obj = importlib.import_module(module)
    for part in qualname.split("."):
        obj = getattr(obj, part)
    return obj


def _api_default(target) -> Any:
    """The default of `target` (`inspect.Parameter.empty` for a required parameter)."""
    obj = _resolve(target.owner)
    if isinstance(target, Field):
        field = {f.name: f for f in dataclasses.fields(obj)}[target.name]
        return field.default_factory() if field.default is dataclasses.MISSING \
            else field.default
    return inspect.signature(obj).parameters[target.name].default


def _norm(v):
    return tuple(v) if isinstance(v, list) else v


#: ``default 16``, ``default: 0.5``, ``default 1e-05`` (not ``default: 90 %``).
STATED = re.compile(r"\bdefault:? (-?\d+(?:\.\d*)?(?:e[-+]?\d+)?)(?![\d.]|\s*%)")


def _stated_defaults(parser, action) -> list[float]:
    text = parser._get_formatter()._expand_help(action) if action.help else ""
    return [float(x) for x in STATED.findall(text)]


def test_every_command_and_option_is_mapped():
    """A command the parser has and `API` has not, or an option with no target, fails."""
    assert set(COMMANDS) == set(API), "commands without a mapped public function"
    unmapped = [(path, a.dest) for path, a in OPTIONS if a.dest not in API[path][1]]
    assert not unmapped, f"options without a target (add them to API or CLI_ONLY): {unmapped}"
    stale = [(path, dest) for path, (_, opts) in API.items() for dest in opts
             if dest not in {a.dest for a in COMMANDS[path]._actions}]
    assert not stale, f"targets of options the parser no longer has: {stale}"


@pytest.mark.parametrize("path, action", OPTIONS,
                         ids=[f"{' '.join(p)} {a.option_strings[-1]}" for p, a in OPTIONS])
def test_option_default_is_the_functions(path, action):
    target = API[path][1][action.dest]
    if isinstance(target, Calls) or (path, action.dest) in DELIBERATE:
        return
    api = _api_default(target)
    for other in getattr(target, "also", ()):
        assert _api_default(Param(other, target.name)) == api, \
            f"{other}'s {target.name} default is not {target.owner}'s ({api!r})"
    if api is inspect.Parameter.empty:                  # an input the function requires
        assert action.default is None, f"{action.dest}: a required argument of {target.owner}"
        return
    if action.default is None and (isinstance(target, Field) or target.none_is_default):
        pass                                  # not given: the field's or the parameter's own
    else:
        assert _norm(target.cli(action.default)) == _norm(api), \
            f"{' '.join(path)} {action.option_strings[-1]}: CLI {action.default!r} -> " \
            f"{target.cli(action.default)!r}, {target.owner}.{target.name} {api!r}"
    for stated in _stated_defaults(COMMANDS[path], action):
        assert target.cli(stated) == pytest.approx(api), \
            f"{' '.join(path)} {action.option_strings[-1]}: help says default {stated:g}, " \
            f"{target.owner}.{target.name} is {api!r}"


def _public(owner: str) -> bool:
    import railnav
    module, _, qualname = owner.partition(":")
    top = qualname.split(".")[0]
    if getattr(railnav, top, None) is _resolve(f"{module}:{top}") and top in railnav.__all__:
        return True
    return top in getattr(importlib.import_module(module), "__all__", ())


def _targets():
    for path, (functions, options) in API.items():
        for owner in functions:
            yield path, owner, None
        for target in options.values():
            for owner in (target.owner, *getattr(target, "also", ())):
                yield path, owner, getattr(target, "name", None)


@pytest.mark.parametrize("path, owner, name", sorted(set(_targets()), key=str))
def test_functions_are_public_and_documented(path, owner, name):
    """Each function (or dataclass) a command maps to is public and has a docstring that
    names the mapped parameter or field."""
    assert _public(owner), f"{owner} is not exported (__all__)"
    doc = inspect.getdoc(_resolve(owner)) or ""
    assert doc, f"{owner} has no docstring"
    if name is not None:
        assert re.search(rf"\b{name}\b", doc + _delegated(doc)), \
            f"{owner}'s docstring does not name {name}"


def _delegated(doc: str) -> str:
    """The docstrings of the functions that "Parameters are those of `f`" names, in turn."""
    found = re.search(r"Parameters are those of\s+`([\w.]+)\.(\w+)`", doc)
    if found is None:
        return ""
    theirs = inspect.getdoc(_resolve(":".join(found.groups()))) or ""
    return theirs + _delegated(theirs)


def test_stated_default_parser():
    """The help-text reader finds what the help texts write, and only that."""
    assert STATED.findall("most live hypotheses (default 16)") == ["16"]
    assert STATED.findall("rate, 1/s (default 1e-05; 0: no crossovers)") == ["1e-05"]
    assert STATED.findall("(default: 0.5) and default 7") == ["0.5", "7"]
    assert STATED.findall("(default: 90 % of it)") == []
    assert STATED.findall("(default: the scenario's)") == []
