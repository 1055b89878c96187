"""The top-level Python API: load a scenario, run it, compare methods on it, run a campaign.

These four functions are what ``redservo run``, ``compare`` and ``campaign`` do, callable
from Python (``import redservo``): :func:`load_scenario`, :func:`run`, :func:`compare`,
:func:`campaign`. For a control loop of your own, :meth:`Experiment.controller
<redservo.experiment.build.Experiment.controller>` (or :class:`redservo.Controller`) gives the
control core a run drives. Every error is one :class:`~redservo.errors.RedservoError`
naming the argument (or file and key) and what is allowed. Units: m, rad, s; joints and
iterations numbered from 0.

>>> import redservo
>>> result = redservo.run("afma6-gaze-demo")
>>> result.outcome, result.summary.success
('converged', True)
>>> from redservo.records import outcome_text   # what the console and compare.md show
>>> outcome_text(result.summary)
'converged — success'

"converged" alone does not say the run was safe: a run that the position shield had to rescue
also converges, and is no success (:func:`redservo.records.verdict` says why not).
"""

from __future__ import annotations

import json
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

from redservo.errors import ConfigurationError
from redservo.experiment.overrides import Overrides
from redservo.experiment.overrides import as_assignments as _assignments

if TYPE_CHECKING:  # pragma: no cover
    from redservo.campaign import CampaignResult
    from redservo.experiment.build import Experiment
    from redservo.scenario import Scenario
    from redservo.simulation import SimulationResult

__all__ = ["Overrides", "ScenarioLike", "campaign", "compare", "load_scenario", "run"]

ScenarioLike = Any
"""What :func:`load_scenario` accepts: a shipped scenario name (``redservo list``), a path
to a TOML file, a scenario table (``dict``), or a :class:`~redservo.scenario.Scenario`."""


def load_scenario(scenario: ScenarioLike, overrides: Overrides = None) -> Scenario:
    """Load and validate a scenario (nothing is built or run).

    Args:
        scenario: A shipped scenario name (``redservo list``), a path to a TOML file
            (docs/scenarios.md), a scenario table (a ``dict`` with the file's keys; relative
            paths in it are read from the current folder), or a loaded scenario.
        overrides: Keys to change, e.g. ``{"control.lam": 0.8}`` (dotted paths;
            ``features[0].variant`` selects an entry of an array of tables).

    Returns:
        The :class:`~redservo.scenario.Scenario` (``.spec``: the validated form with every
        default, ``.data``: the table).

    Raises:
        ScenarioError: unknown name, missing file, or an invalid key or value (one line
            naming the file and the key).

    >>> import redservo
    >>> sc = redservo.load_scenario("afma6-gaze-demo", {"control.lam": 0.8})
    >>> sc.name, sc.method, sc.spec.control.lam
    ('afma6-gaze-demo', 'iterative-smooth', 0.8)
    >>> table = {
    ...     "robot": {"model": "afma6", "q0": [0, 0, 0, 0, 1.0, 0]},
    ...     "objects": [{"name": "dot", "kind": "points", "points": [[0, 0, 0]],
    ...                  "pose_in_camera": {"translation": [0.05, 0.02, 0.6]}}],
    ...     "features": [{"kind": "point", "object": "dot"}],
    ...     "task": {"desired": [0.0, 0.0]},
    ...     "control": {"method": "gpm"},
    ... }
    >>> redservo.load_scenario(table).spec.control.method
    'gpm'
    """
    from redservo.scenario import Scenario, apply_overrides, parse_scenario
    from redservo.scenario import load_scenario as load_file

    if isinstance(scenario, Scenario):
        sc = scenario
    elif isinstance(scenario, Mapping):
        sc = parse_scenario(scenario, "<dict>")
    elif isinstance(scenario, str | Path):
        sc = load_file(scenario)
    else:
        raise ConfigurationError(
            f"scenario: give a shipped name, a path, a dict or a Scenario, got "
            f"{type(scenario).__name__}",
            argument="scenario",
        )
    sets = _assignments(overrides)
    return apply_overrides(sc, sets) if sets else sc


def _experiment(scenario: ScenarioLike, overrides: Overrides) -> Experiment:
    from redservo.experiment.build import build

    return build(load_scenario(scenario, overrides))


def run(
    scenario: ScenarioLike,
    *,
    method: str | None = None,
    overrides: Overrides = None,
    out: str | Path | None = None,
    progress: Callable[[int], None] | None = None,
    **options: Any,
) -> SimulationResult:
    """Simulate one scenario, as ``redservo run`` does (without figures).

    Args:
        scenario: What :func:`load_scenario` accepts.
        method: Another control method than the scenario's (``redservo.METHODS``).
        overrides: Scenario keys to change (:func:`load_scenario`).
        out: Save the run there (``summary.json``, ``log.npz``, the resolved
            ``scenario.toml``, ...: a self-contained run directory, :func:`redservo.load_run`).
        progress: Called with each iteration index (0-based).
        **options: Fields of :class:`~redservo.simulation.SimulationOptions` to replace for
            this run, e.g. ``max_iterations=100``.

    Returns:
        The :class:`~redservo.simulation.SimulationResult`: ``outcome``, ``summary`` (typed:
        ``success``, ``iterations``, ``final_error_norm``, ...) and ``log`` (arrays per
        iteration: ``q`` (N, n), ``e``, ``camera_twist``, ...). Show the outcome with its
        success verdict: :func:`redservo.records.outcome_text` (``"converged — no success:
        the shield acted at 12 step(s)"``).

    Raises:
        ScenarioError: an invalid scenario or override.
        UnknownNameError: an unknown method.

    >>> import redservo
    >>> r = redservo.run("afma6-gaze-demo", method="gpm", max_iterations=20)
    >>> r.outcome, r.summary.iterations, r.log.q.shape
    ('max_iterations', 20, (20, 6))
    >>> from redservo.records import verdict
    >>> verdict(r.summary)
    'no success: iteration cap reached (20 iterations) before convergence'
    """
    exp = _experiment(scenario, overrides)
    result = exp.run(method=method, progress=progress, **options)
    if out is not None:
        sc = exp.scenario
        name = method or sc.method
        result.save(out, extra={"scenario": sc.name, "source": sc.source, "method": name})
    return result


def compare(
    scenario: ScenarioLike,
    methods: Sequence[str],
    *,
    overrides: Overrides = None,
    out: str | Path | None = None,
    **options: Any,
) -> dict[str, SimulationResult]:
    """Run several methods on one scenario, as ``redservo compare`` does (without figures).

    Args:
        scenario: What :func:`load_scenario` accepts.
        methods: Method names (``redservo.METHODS``), at least one; each is checked before
            anything runs.
        overrides: Scenario keys to change (:func:`load_scenario`).
        out: Save there one run directory per method, ``compare.json`` and ``compare.md``
            (``redservo plot OUT`` then draws the overlaid figures).
        **options: Fields of :class:`~redservo.simulation.SimulationOptions` to replace.

    Returns:
        ``{method: SimulationResult}`` in the order given.

    Raises:
        ConfigurationError: no method given.
        UnknownNameError: an unknown method.

    >>> import redservo
    >>> results = redservo.compare("afma6-gaze-demo", ["classical", "gpm"])
    >>> from redservo.records import outcome_text
    >>> {m: outcome_text(r.summary) for m, r in results.items()}
    {'classical': 'converged — success', 'gpm': 'converged — success'}
    """
    names = [methods] if isinstance(methods, str) else list(methods)
    if not names:
        raise ConfigurationError("methods: give at least one method name", argument="methods")
    check_methods(names)  # unknown names fail before anything runs
    exp = _experiment(scenario, overrides)
    results = {m: exp.run(method=m, **options) for m in names}
    if out is not None:
        write_comparison(Path(out), exp.scenario.name, results)
    return results


def check_methods(names: Sequence[str]) -> None:
    """Raise :class:`~redservo.errors.UnknownNameError` for the first name that is no
    registered law, in one line with the known names and the closest one ("did you mean")."""
    from redservo.errors import UnknownNameError
    from redservo.redundancy import law_class
    from redservo.redundancy.base import registered_methods
    from redservo.schema.base import unknown_name

    for m in names:
        try:
            law_class(m)
        except UnknownNameError:
            raise UnknownNameError(unknown_name("method", m, list(registered_methods()))) from None


def write_comparison(out: Path, name: str, results: Mapping[str, SimulationResult]) -> None:
    """Save a comparison: one run directory per method, ``compare.json`` and ``compare.md``."""
    from redservo.runs.tables import summary_table

    for m, r in results.items():
        r.save(out / m, extra={"scenario": name, "method": m})
    rows = {m: r.summary.to_dict() for m, r in results.items()}
    (out / "compare.json").write_text(json.dumps({"scenario": name, "methods": rows}, indent=2))
    (out / "compare.md").write_text(f"# {name}\n\n" + summary_table(rows) + "\n")


def campaign(
    definition: str | Path,
    *,
    methods: Sequence[str] | None = None,
    samples: int | None = None,
    seed: int = 0,
    workers: int | None = 1,
    overrides: Overrides = None,
    out: str | Path | None = None,
    progress: bool = False,
) -> CampaignResult:
    """Run a Monte Carlo campaign, as ``redservo campaign`` does: every method on the same
    random variations of a scenario (docs/campaigns.md).

    Args:
        definition: A shipped campaign name (``redservo list``) or a campaign TOML file.
        methods: Methods to compare (default: the campaign's list).
        samples: Number of random variations (default: the campaign's).
        seed: Random seed; the results do not depend on ``workers``.
        workers: Parallel processes (default 1; None: every core).
        overrides: Keys of the base scenario to change (:func:`load_scenario`), after the
            campaign's own overrides.
        out: Store the rows there (``samples.csv``, resumable), with ``campaign.md``,
            ``campaign.json`` and the figures; None writes nothing.
        progress: Progress lines on stderr.

    Returns:
        The :class:`~redservo.campaign.CampaignResult`: ``stats`` per method (success rate
        with its Wilson interval, limit hits, iteration percentiles, ...), ``rows``,
        ``markdown``.

    >>> import redservo
    >>> res = redservo.campaign("afma6-gaze-demo", methods=["gpm"], samples=2)
    >>> res.samples, res.methods
    (2, ('gpm',))
    """
    from redservo.campaign import campaign_call

    return campaign_call(
        definition,
        methods=methods,
        samples=samples,
        seed=seed,
        workers=workers,
        overrides=overrides,
        out=out,
        progress=progress,
    )
