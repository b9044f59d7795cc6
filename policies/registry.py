"""Policies by name or spec: the one table that the command line, the training envs and the
benchmarks build their policies from.

A policy is chosen by a *spec*:

- a name of the built-in tables ``DEFENDERS`` / ``ATTACKERS``;
- a name that an installed package declares in the entry-point group
  ``reachavoid.defenders`` / ``reachavoid.attackers`` (built-in names win);
- ``pkg.module:factory``: any importable callable;
- ``SCHEME:REST`` for a scheme of ``SCHEMES`` (policies made from a file, say);
- in Python, the factory itself.

A factory is ``factory(scenario, **options) -> reachavoid_env.Policy`` (a class whose
constructor takes the scenario first works). Its options are its own keyword parameters
(``inspect.signature``; a ``**kwargs`` factory takes any), never a hand-kept list:
``make_policy`` refuses an option the factory does not take, and ``policy_specs`` hands
each of several policies the options it takes and refuses an option that none takes
(VMAS's ``check_kwargs_consumed``). ``seed`` and ``progress`` are *supplied* options: the
program passes them (an episode's seed, progress bars) to the factories that take them.

    from policies.registry import make_policy
    defenders = make_policy("defenders", "hj", scenario, grid1=31, grid2=15)

``make_batch_policy`` builds the same choice for K copies of a game
(``reachavoid_env.BatchPolicy``): the batched class of ``BATCHED`` where the name has one
and it takes every option given, else ``reachavoid_env.PerCopy`` of the policy.
"""

from __future__ import annotations

import functools
import importlib
import inspect
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from importlib import metadata
from typing import TYPE_CHECKING, Any

from reachavoid_env.checks import FieldError

if TYPE_CHECKING:
    from reachavoid_env import BatchPolicy, Policy, Scenario

Factory = Callable[..., "Policy"]
"""``factory(scenario, **options) -> Policy``."""

SUPPLIED = ("seed", "progress")
"""Options the program supplies when it builds a policy (an episode's seed, progress bars),
to the factories that take them; ``policy_specs`` does not hand them out."""

ENTRY_POINT_GROUPS = {"defenders": "reachavoid.defenders", "attackers": "reachavoid.attackers"}

SCHEMES: dict[str, str] = {"sb3": "policies.learned:sb3_named_policy"}
"""Spec prefixes: a spec ``SCHEME:REST`` is resolved by the function ``SCHEMES[SCHEME]`` (a
``module:function`` reference, imported on first use) called as ``function(side, spec)``;
it returns the ``NamedPolicy`` (options from its ``build``'s signature) or raises a
``FieldError`` naming ``side``. A prefix listed here wins over a module of that name."""


def scenario_free(policy: type) -> Factory:
    """The factory of a policy class whose constructor does not need the scenario: it takes
    the scenario and the constructor's own keyword parameters as options."""
    def build(scenario: Scenario, **options: Any) -> Policy:
        return policy(**options)
    own = inspect.signature(policy).parameters.values()
    scenario_parameter = inspect.Parameter("scenario", inspect.Parameter.POSITIONAL_OR_KEYWORD)
    build.__signature__ = inspect.Signature([scenario_parameter, *own])  # type: ignore[attr-defined]
    build.__doc__ = policy.__doc__
    return build


@dataclass(frozen=True)
class NamedPolicy:
    """A policy choice: one line of help and its factory, ``build(scenario, **options)``.

    ``factory`` is the factory or ``"module:attribute"``, imported on first use (so reading
    the tables, as ``--help`` does, imports no policy); ``scenario=False`` marks a policy
    class whose constructor takes no scenario (``scenario_free``).
    """

    help: str
    factory: str | Factory
    scenario: bool = True

    @functools.cached_property
    def build(self) -> Factory:
        factory = (_import(self.factory, self.help) if isinstance(self.factory, str)
                   else self.factory)
        return factory if self.scenario else scenario_free(factory)

    @functools.cached_property
    def options(self) -> frozenset[str] | None:
        """The option names ``build`` takes (its keyword parameters after the scenario), or
        ``None`` when it takes any (``**kwargs``)."""
        return factory_options(self.build)

    def takes(self, option: str) -> bool:
        return self.options is None or option in self.options


def factory_options(factory: Factory) -> frozenset[str] | None:
    """The keyword parameters of ``factory`` after its first (the scenario); ``None`` when
    it has ``**kwargs``. A factory that takes no scenario is a ``ValueError``."""
    try:
        parameters = list(inspect.signature(factory).parameters.values())
    except (TypeError, ValueError):
        raise FieldError(f"{_label(factory)}: cannot read the factory's signature",
                         _label(factory)) from None
    positional = (inspect.Parameter.POSITIONAL_ONLY, inspect.Parameter.POSITIONAL_OR_KEYWORD,
                  inspect.Parameter.VAR_POSITIONAL)
    if not parameters or parameters[0].kind not in positional:
        raise FieldError(f"{_label(factory)}: a policy factory takes the scenario first, "
                         f"as factory(scenario, **options)", _label(factory))
    rest = parameters[1:]
    if any(p.kind is inspect.Parameter.VAR_KEYWORD for p in rest):
        return None
    return frozenset(p.name for p in rest if p.kind in (
        inspect.Parameter.POSITIONAL_OR_KEYWORD, inspect.Parameter.KEYWORD_ONLY))


def _label(factory: Any) -> str:
    return f"{getattr(factory, '__module__', '?')}:{getattr(factory, '__qualname__', factory)}"


def _first_line(factory: Any) -> str:
    return (inspect.getdoc(factory) or "").strip().split("\n")[0]


DEFENDERS: dict[str, NamedPolicy] = {
    "hj": NamedPolicy("the reference: HJ tubes + the paper's assignment MIP (CP-SAT), "
                      "re-solved every step; certified games kept, the team's intercept plan "
                      "played as far as the certificates allow, an uncertified game's control "
                      "kept while the plan chases its attacker",
                      "policies.defenders:HJDefenderPolicy.for_scenario"),
    "hj-pairs": NamedPolicy("the reference with defender teams: two defenders may share an "
                            "attacker neither stops alone (1 vs 2 tube), re-solved every step",
                            "policies.defenders:HJPairsDefenderPolicy.for_scenario"),
    "paper": NamedPolicy("the paper's Algorithm 1 exactly: HJ tubes + the assignment MIP, "
                         "every value > 0 a defender win, unassigned defenders stand still",
                         "policies.defenders:HJDefenderPolicy.paper"),
    "matching": NamedPolicy("the maximum-matching baseline (unmatched defenders stand still)",
                            "policies.defenders:MatchingDefenderPolicy.for_scenario"),
    "intercept": NamedPolicy("the time-to-intercept heuristic: each defender races the most "
                             "threatening attacker it can cut off to a point of its shortest "
                             "path, spare defenders back up",
                             "policies.intercept:InterceptDefender", scenario=False),
    "learned-mappo": NamedPolicy("a MAPPO actor shared by the defenders (trained on the "
                                 "default suite's random starts, up to 8 attackers and 4 "
                                 "defenders), played with numpy from shipped weights",
                                 "policies.mappo:learned_mappo"),
    "greedy": NamedPolicy("chase the nearest active attacker",
                          "policies.greedy:GreedyDefender", scenario=False),
    "idle": NamedPolicy("stand still", "policies.defenders:IdleDefender", scenario=False),
}

ATTACKERS: dict[str, NamedPolicy] = {
    "shortest-path": NamedPolicy("the time-optimal path to the target around obstacles, "
                                 "ignoring defenders (the paper's attackers)",
                                 "policies.attackers:ShortestPathAttacker", scenario=False),
    "hj": NamedPolicy("1 vs 1 optimal control against the most dangerous defender",
                      "policies.attackers:HJAttacker.for_scenario"),
    "hj-pairs": NamedPolicy("attackers that lose their 1 vs 1 game play the 2 vs 1 game in "
                            "pairs (2 vs 1 tube), the others the shortest path",
                            "policies.attackers:HJPairsAttacker.for_scenario"),
    "straight": NamedPolicy("run straight for the nearest target centre",
                            "policies.attackers:StraightAttacker", scenario=False),
    "random": NamedPolicy("run in random directions, redrawn every 0.25 s",
                          "policies.attackers:RandomAttacker", scenario=False),
}

TABLES = {"defenders": DEFENDERS, "attackers": ATTACKERS}


def _check_side(side: str) -> None:
    if side not in TABLES:
        raise FieldError(f"side: expected 'defenders' or 'attackers', got {side!r}", "side")


def installed(side: str) -> dict[str, metadata.EntryPoint]:
    """The entry points of installed packages in ``side``'s group (built-in names win)."""
    _check_side(side)
    found = metadata.entry_points(group=ENTRY_POINT_GROUPS[side])
    return {ep.name: ep for ep in found if ep.name not in TABLES[side]}


def policy_names(side: str) -> list[str]:
    """Every name a spec may use on ``side``: the built-ins, then the installed ones."""
    _check_side(side)
    return [*TABLES[side], *installed(side)]


def names_help(side: str) -> str:
    """One line per choice for ``--help``: built-ins with their help, installed names with
    their package (not imported: help stays fast)."""
    built_in = [f"{name}: {choice.help}" for name, choice in TABLES[side].items()]
    plugins = [f"{name}: from {ep.dist.name if ep.dist else ep.value}"
               for name, ep in installed(side).items()]
    return "; ".join(built_in + plugins)


def _import(reference: str, label: str, field: str | None = None) -> Any:
    """The object of ``module:attribute`` (dots allowed on both sides); an error's message
    starts with ``label``, its ``field`` is ``field`` (default ``label``). Ours, not
    ``pkgutil.resolve_name``: that raises a module's own errors as the same types as a
    malformed name (``ValueError``) or a missing attribute (``AttributeError``)."""
    field = field or label
    module_name, _, attribute = reference.partition(":")
    if not module_name or not attribute:
        raise FieldError(f"{label}: expected pkg.module:factory, got {reference!r}", field)
    try:
        target: Any = importlib.import_module(module_name)
    except Exception as err:   # a bad name (``..``), a missing module, or the module's own error
        raise FieldError(f"{label}: cannot import {module_name!r} ({type(err).__name__}: "
                         f"{err})", field) from None
    for part in attribute.split("."):
        if not hasattr(target, part):
            raise FieldError(f"{label}: module {module_name!r} has no {attribute!r}", field)
        target = getattr(target, part)
    if not callable(target):
        raise FieldError(f"{label}: {reference!r} is not callable", field)
    return target


@functools.cache
def resolve(side: str, spec: str) -> NamedPolicy:
    """The policy of a string ``spec`` on ``side`` (see the module docstring); a spec that
    names nothing is a ``FieldError`` naming ``side``."""
    _check_side(side)
    if spec in TABLES[side]:
        return TABLES[side][spec]
    plugins = installed(side)
    if spec in plugins:
        factory = plugins[spec].load()
        factory_options(factory)
        return NamedPolicy(_first_line(factory), factory)
    scheme, colon, _ = spec.partition(":")
    if colon and scheme in SCHEMES:
        choice = _import(SCHEMES[scheme], f"{side} scheme {scheme!r}", side)(side, spec)
        factory_options(choice.build)
        return choice
    if colon:
        factory = _import(spec, side)
    else:
        raise FieldError(f"{side}: unknown policy {spec!r} (choices: "
                         f"{', '.join(policy_names(side))}, or pkg.module:factory)", side)
    factory_options(factory)
    return NamedPolicy(_first_line(factory), factory)


@dataclass(frozen=True)
class PolicySpec:
    """A policy choice and its options as a picklable value: what the sweeps' workers and
    the training envs' subprocesses build their policies from (they resolve ``source``
    themselves: a module spec is imported there).

    ``side``: ``"defenders"`` or ``"attackers"``; ``source``: a string spec or a factory;
    ``options``: sorted ``(key, value)`` pairs, each taken by the factory. Calling it with a
    scenario builds the policy; ``supplied`` options (``seed``, ``progress``) go in only
    where the factory takes them.
    """

    side: str
    source: str | Factory
    options: tuple[tuple[str, Any], ...] = ()

    def __post_init__(self) -> None:
        choice = self.choice
        unknown = sorted(key for key, _ in self.options if not choice.takes(key))
        if unknown:
            accepted = ", ".join(sorted(choice.options or ())) or "none"
            raise FieldError(f"{self.side} {self.label!r}: unknown option(s) {unknown} "
                             f"(accepted: {accepted})", self.side)

    @classmethod
    def of(cls, side: str, source: str | Factory, **options: Any) -> PolicySpec:
        return cls(side, source, tuple(sorted(options.items())))

    @property
    def choice(self) -> NamedPolicy:
        if isinstance(self.source, str):
            return resolve(self.side, self.source)
        _check_side(self.side)
        factory_options(self.source)
        return NamedPolicy(_first_line(self.source), self.source)

    @property
    def label(self) -> str:
        """The spec as given, or ``module:name`` of a factory."""
        return self.source if isinstance(self.source, str) else _label(self.source)

    @property
    def seeded(self) -> bool:
        """Whether the factory takes a ``seed`` (then every episode gets its own)."""
        return self.choice.takes("seed")

    def __call__(self, scenario: Scenario, **supplied: Any) -> Policy:
        unknown = sorted(set(supplied) - set(SUPPLIED))
        if unknown:
            raise FieldError(f"{unknown}: not supplied options ({', '.join(SUPPLIED)}); "
                             f"options go in the spec", unknown[0])
        choice = self.choice
        extra = {key: value for key, value in supplied.items() if choice.takes(key)}
        return choice.build(scenario, **(dict(self.options) | extra))


def make_policy(side: str, source: str | Factory, scenario: Scenario, **options: Any) -> Policy:
    """Build the policy ``source`` (a spec or a factory) for ``scenario``; an option it does
    not take is an error."""
    return PolicySpec.of(side, source, **options)(scenario)


BATCHED: dict[str, dict[str, NamedPolicy]] = {
    "defenders": {
        "hj": NamedPolicy("hj on K copies in one call",
                          "policies.batch_defenders:BatchHJDefenders.for_scenario"),
        "greedy": NamedPolicy("greedy on K copies in one call",
                              "policies.greedy:BatchGreedyDefenders", scenario=False),
        "intercept": NamedPolicy("intercept on K copies in one call",
                                 "policies.intercept:BatchInterceptDefenders", scenario=False),
        **{name: DEFENDERS[name] for name in ("hj-pairs", "paper", "matching")},
    },
    "attackers": {},
}
"""Names with a batched class (``reachavoid_env.BatchPolicy``), acting on every copy as
the single policy of that name does, bit for bit; a factory here that builds a
``reachavoid_env.Single`` (the assignment engine at one copy: ``hj-pairs``, ``paper``,
``matching``) gives its engine."""


def make_batch_policy(side: str, source: str | Factory, scenario: Scenario,
                      **options: Any) -> BatchPolicy:
    """The policy ``source`` (as ``make_policy``) for K copies of ``scenario``'s game: its
    ``BATCHED`` class where it has one that takes every option given, else a
    ``reachavoid_env.PerCopy`` of the single policy (built per copy and map)."""
    spec = PolicySpec.of(side, source, **options)
    batched = BATCHED[side].get(source) if isinstance(source, str) else None
    from reachavoid_env import PerCopy, Single

    if batched is not None and all(batched.takes(option) for option in options):
        policy = batched.build(scenario, **options)
        return policy.batch if isinstance(policy, Single) else policy

    return PerCopy(spec, side)


def policy_specs(choices: Sequence[tuple[str, str | Factory]], options: Mapping[str, Any],
                 names: Mapping[str, str] | None = None) -> list[PolicySpec]:
    """One ``PolicySpec`` per ``(side, source)`` choice, each with the ``options`` its
    factory takes. An option that no choice takes is a ``FieldError`` naming it (as
    ``names[option]`` when given, e.g. the command-line flag); ``seed`` and ``progress``
    are supplied when building, not here."""
    resolved = [PolicySpec(side, source) for side, source in choices]
    for option in options:
        if option in SUPPLIED:
            raise FieldError(f"{option}: supplied to each policy when it is built, "
                             f"not an option here", option)
        if not any(spec.choice.takes(option) for spec in resolved):
            field = (names or {}).get(option, option)
            chosen = ", ".join(spec.label for spec in resolved)
            raise FieldError(f"{field}: no chosen policy takes it ({chosen})", field)
    return [PolicySpec.of(spec.side, spec.source,
                          **{k: v for k, v in options.items() if spec.choice.takes(k)})
            for spec in resolved]
