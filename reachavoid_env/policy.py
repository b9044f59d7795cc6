"""The policy protocols: ``Policy`` (one side of one game) and ``BatchPolicy`` (one side of
K copies in one call), and the adapters between them: ``PerMapPolicy`` (one ``Policy``
per map of a library), ``PerCopy`` (a batched policy made of one ``PerMapPolicy`` per
copy), ``PerMap`` (one batched policy per map) and ``Single`` (a batched policy played as
one ``Policy``); ``build_policy`` (a policy or a factory of one, checked); the union of
several policies' overlays (``merged_overlay``)."""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Sequence
from typing import TYPE_CHECKING, Any, Protocol, runtime_checkable

import numpy as np

from reachavoid_env.game_state import AttackerStatus, BatchState, GameState
from reachavoid_env.overlay import Overlay

if TYPE_CHECKING:
    from reachavoid_env.scenario import Scenario


class PolicyMismatch(ValueError):
    """A policy that cannot play a scenario (for example a learned model trained for other
    player counts): bad input, reported in one line by the command line."""


@runtime_checkable
class Policy(Protocol):
    """Controls one side (all attackers or all defenders) of a game.

    ``reset(scenario)`` is called once per episode with the scenario in play (starts
    included). ``act(state)`` returns an action for every live agent the policy controls,
    keyed by agent name: a float32 array ``(2,)`` in ``[-1, 1]``, the desired velocity as a
    fraction of that player's speed (the env's action space). A policy that has something
    to show (assignment edges, text) also defines ``overlay() -> Overlay | None``; it is
    optional, and read only through ``merged_overlay``.
    """

    def reset(self, scenario: Scenario) -> None: ...

    def act(self, state: GameState) -> dict[str, np.ndarray]: ...


def merged_overlay(*policies: Policy) -> Overlay | None:
    """The union of the policies' overlays (edges with their kinds and routes, text lines);
    ``None`` if none draws."""
    overlays = []
    for policy in policies:
        overlay = getattr(policy, "overlay", None)
        if callable(overlay) and (drawn := overlay()) is not None:
            overlays.append(drawn)
    if not overlays:
        return None
    routed = [o for o in overlays if o.ways is not None]
    return Overlay(edges=tuple(e for o in overlays for e in o.edges),
                   lines=tuple(line for o in overlays for line in o.lines),
                   kinds=tuple(e.kind for o in overlays for e in o.kinded_edges),
                   ways=(lambda: tuple(r for o in routed for r in o.routes)) if routed else None)


@runtime_checkable
class BatchPolicy(Protocol):
    """Controls one side of K copies of a game in one call.

    ``reset_copies(copies, scenarios)``: a new episode starts in each copy of ``copies``
    (an int array) with ``scenarios[i]`` (starts included) for ``copies[i]``; called for
    every copy after the vector env's reset, and for the copies that autoreset after each
    step. ``act_batch(states)``: ``(K, n, 2)`` float32 controls, ``|u| <= 1``, for the
    players this policy drives (``n = N`` for a defender policy, ``M`` for an attacker
    policy), rows in agent order; the env ignores the rows of players out of the game.
    Copy ``k``'s rows are exactly (bit for bit) what the single-game policy's ``act``
    gives for ``states.game_state(k)``.
    """

    def reset_copies(self, copies: np.ndarray, scenarios: Sequence[Scenario]) -> None: ...

    def act_batch(self, states: BatchState) -> np.ndarray: ...


def checked_copies(copies: np.ndarray, scenarios: Sequence[Scenario]) -> np.ndarray:
    """``copies`` of ``BatchPolicy.reset_copies`` as an int array, checked to have one
    scenario each."""
    copies = np.asarray(copies, dtype=np.int64).reshape(-1)
    if len(copies) != len(scenarios):
        raise ValueError(f"scenarios: expected one per copy ({len(copies)}), got "
                         f"{len(scenarios)}")
    return copies


def map_key(scenario: Scenario) -> Scenario:
    """``scenario`` without its starts: what a policy built for a map depends on."""
    return dataclasses.replace(scenario, attackers=None, defenders=None)


def build_policy(source: Any, scenario: Scenario, field: str) -> Policy:
    """A policy from ``source``: a policy object as it is, or a factory called with
    ``scenario``. ``TypeError`` naming ``field`` otherwise."""
    if isinstance(source, type):
        raise TypeError(f"{field}: got the class {source.__name__}; pass an instance or a "
                        f"factory taking the scenario")
    if isinstance(source, Policy):
        return source
    if callable(source):
        policy = source(scenario)
        if not isinstance(policy, Policy):
            raise TypeError(f"{field}: the factory returned {type(policy).__name__}, which has "
                            f"no reset(scenario) and act(state)")
        return policy
    raise TypeError(f"{field}: expected a policy (reset(scenario), act(state)) or a factory "
                    f"scenario -> policy, got {type(source).__name__}")


class PerMapPolicy:
    """A ``Policy`` per map of a library, built by ``factory`` the first time its map is
    played (``first``, if given, at once, so that a bad factory fails early) and kept for
    later episodes on that map. ``reset(scenario)`` picks the map's policy; ``act`` and
    ``overlay`` are its. ``field`` names the factory in ``build_policy``'s errors."""

    def __init__(self, factory: Callable[[Scenario], Policy], field: str,
                 first: Scenario | None = None) -> None:
        self.factory, self.field = factory, field
        self.built: dict[Scenario, Policy] = {}
        self.current = self._for(first) if first is not None else None

    def _for(self, scenario: Scenario) -> Policy:
        key = map_key(scenario)
        if key not in self.built:
            self.built[key] = build_policy(self.factory, key, self.field)
        return self.built[key]

    def reset(self, scenario: Scenario) -> None:
        self.current = self._for(scenario)
        self.current.reset(scenario)

    def act(self, state: GameState) -> dict[str, np.ndarray]:
        if self.current is None:
            raise RuntimeError("act: call reset(scenario) first")
        return self.current.act(state)

    def overlay(self) -> Overlay | None:
        overlay = getattr(self.current, "overlay", None)
        return overlay() if overlay is not None else None


class PerCopy:
    """A ``BatchPolicy`` made of one ordinary ``Policy`` per copy and map: copy ``k`` plays
    a ``PerMapPolicy`` of ``factory`` (a map's policy built the first time the copy plays
    it, kept for later episodes on that map), and ``act_batch`` loops
    ``act(states.game_state(k))``. The fallback for policies without a batched class, and
    the reference the batched ones are tested against.

    ``side`` (``"defenders"`` or ``"attackers"``) says which players' rows ``act_batch``
    returns; a player the policy gives no action (one out of the game) gets zeros.
    """

    def __init__(self, factory: Callable[[Scenario], Policy], side: str = "defenders") -> None:
        if side not in ("defenders", "attackers"):
            raise ValueError(f"side: expected 'defenders' or 'attackers', got {side!r}")
        self.factory = factory
        self.side = side
        self._per_copy: list[PerMapPolicy | None] = []

    @property
    def policies(self) -> list[Policy | None]:
        """Each copy's policy of its current map (``None``: a copy not reset yet)."""
        return [None if per_map is None else per_map.current for per_map in self._per_copy]

    def reset_copies(self, copies: np.ndarray, scenarios: Sequence[Scenario]) -> None:
        copies = checked_copies(copies, scenarios)
        if len(copies):
            self._per_copy += [None] * max(int(copies.max()) + 1 - len(self._per_copy), 0)
        for k, scenario in zip(copies.tolist(), scenarios, strict=True):
            if self._per_copy[k] is None:
                self._per_copy[k] = PerMapPolicy(self.factory, self.side)
            self._per_copy[k].reset(scenario)

    def act_batch(self, states: BatchState) -> np.ndarray:
        players = states.defender_positions if self.side == "defenders" else \
            states.attacker_positions
        count, n = players.shape[:2]
        per_copy = self._per_copy[:count]
        if len(per_copy) < count or any(p is None for p in per_copy):
            raise RuntimeError("act_batch: call reset_copies for every copy first")
        prefix = "defender_" if self.side == "defenders" else "attacker_"
        actions = np.zeros((count, n, 2), dtype=np.float32)
        for k, per_map in enumerate(per_copy):   # its map's policy, without the hop
            for name, action in per_map.current.act(states.game_state(k)).items():
                actions[k, int(name.removeprefix(prefix))] = action
        return actions


class PerMap:
    """A ``BatchPolicy`` made of one ``BatchPolicy`` per map, for copies that play several
    maps: ``factory(scenario)`` builds a map's policy the first time a copy plays it (the
    scenario without its starts), and ``act_batch`` asks each map's policy once for all the
    copies on that map. Each map's policy sees every copy's row (its own copy slots, as on
    one map); the rows of copies on other maps reach it with every attacker out of the game,
    and their actions are not taken. So each copy gets what its map's policy gives it, and a
    batched class that matches its single policy bit for bit keeps doing so over many maps.
    """

    def __init__(self, factory: Callable[[Scenario], BatchPolicy]) -> None:
        self.factory = factory
        self.policies: list[BatchPolicy] = []
        self._maps: dict[Any, int] = {}             # a map's scenario -> its policy's index
        self._map_of = np.zeros(0, dtype=np.intp)  # copy -> its map's index (-1: not reset)

    def reset_copies(self, copies: np.ndarray, scenarios: Sequence[Scenario]) -> None:
        copies = checked_copies(copies, scenarios)
        if len(copies):
            self._grow(int(copies.max()) + 1)
        for k, scenario in zip(copies.tolist(), scenarios, strict=True):
            key = map_key(scenario)
            if key not in self._maps:
                self._maps[key] = len(self.policies)
                self.policies.append(policy := self.factory(key))
                slots = np.arange(len(self._map_of))
                policy.reset_copies(slots, [key] * len(slots))
            self._map_of[k] = self._maps[key]
            self.policies[self._map_of[k]].reset_copies(np.array([k]), [scenario])

    def _grow(self, count: int) -> None:
        """Slots for copies up to ``count``, reset on every map built so far."""
        new = np.arange(len(self._map_of), count)
        if not len(new):
            return
        self._map_of = np.concatenate([self._map_of, np.full(len(new), -1, dtype=np.intp)])
        for key, index in self._maps.items():
            self.policies[index].reset_copies(new, [key] * len(new))

    def act_batch(self, states: BatchState) -> np.ndarray:
        count = len(states.step)
        maps = self._map_of[:count]
        if len(maps) < count or (maps < 0).any():
            raise RuntimeError("act_batch: call reset_copies for every copy first")
        actions: np.ndarray | None = None
        for index in np.unique(maps).tolist():
            here = maps == index
            status = np.where(here[:, None], states.attacker_status,
                              AttackerStatus.CAPTURED.code).astype(np.int8)
            acted = self.policies[index].act_batch(states._replace(attacker_status=status))
            if actions is None:
                actions = np.zeros_like(acted)
            actions[here] = acted[here]
        return actions


class Single:
    """A ``BatchPolicy`` played as an ordinary ``Policy``: one game, copy 0 of ``batch``.

    ``reset(scenario)`` resets copy 0; ``act(state)`` gives copy 0's rows of
    ``batch.act_batch`` keyed by agent name: every defender (``side="defenders"``) or every
    active attacker (``side="attackers"``), float32 ``(2,)`` each. ``overlay()`` is
    ``batch.overlay(0)`` where the batched policy draws (``None`` otherwise); any other
    attribute is read from ``batch``, but for ``BatchPolicy``'s own methods: a ``Single``
    is a ``Policy``, never taken for a ``BatchPolicy`` (whose copies it would share).
    """

    _UNSHARED = frozenset({"batch", "side", "reset_copies", "act_batch"})

    def __init__(self, batch: BatchPolicy, side: str = "defenders") -> None:
        if side not in ("defenders", "attackers"):
            raise ValueError(f"side: expected 'defenders' or 'attackers', got {side!r}")
        self.batch = batch
        self.side = side

    def reset(self, scenario: Scenario) -> None:
        self.batch.reset_copies(np.zeros(1, dtype=np.int64), [scenario])

    def act(self, state: GameState) -> dict[str, np.ndarray]:
        batch = BatchState.of([state])
        if state.velocities is not None:
            batch = batch._replace(velocities=state.velocities[None])
        rows = self.batch.act_batch(batch)[0]
        if self.side == "defenders":
            return dict(zip(state.defender_names, rows, strict=True))
        return {name: rows[i] for i, name in enumerate(state.attacker_names)
                if state.attacker_status[i] is AttackerStatus.ACTIVE}

    def overlay(self) -> Overlay | None:
        overlay = getattr(self.batch, "overlay", None)
        return overlay(0) if callable(overlay) else None

    def __getattr__(self, name: str) -> Any:
        if name in self._UNSHARED or name.startswith("__"):
            raise AttributeError(name)   # not forwarded (or, while copying, not set yet)
        return getattr(self.batch, name)
