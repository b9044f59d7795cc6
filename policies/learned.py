"""Learned policies as ``reachavoid_env.Policy``: a trained network plays wherever a
scripted policy does (``run_episode``, ``reachavoid play`` / ``bench``, the scripted side
of a training env), so it is benchmarked, recorded and compared the same way.

    from policies.learned import ObservationPolicy, load_sb3
    attackers = load_sb3("runs/attacker/model.zip")         # a Stable-Baselines3 model
    attackers = ObservationPolicy(lambda obs: my_net(obs))  # any function of observations

On the command line a model is the policy spec ``sb3:PATH``
(``reachavoid play --attackers sb3:runs/attacker/model.zip``): the scheme ``sb3`` of
``policies.registry.SCHEMES`` resolves it with ``sb3_named_policy``. Stable-Baselines3
(and torch) are imported only when a model is named. A model file is code (loading it
unpickles it): it is read only when nobody but this user or root can change it or its
folders (``check_model_file``), and its weights must be finite.

A policy trained with ``action_repeat = k`` (``reachavoid_env.wrappers``) chose an action
every ``k`` env steps and held it; played here it does the same, so it sees the game at
the rate it was trained on. The training examples store ``k`` in the saved model
(``TRAINING_ATTRIBUTE``); ``load_sb3`` reads it back. A policy trained with full-speed
actions (``full_speed``: every action scaled to length 1, ``rules.unit_vectors``, so the
network picks a heading and the player always runs at its speed) is played so too.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import asdict
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from reachavoid_env import GameState, PolicyMismatch, Scenario, checks
from reachavoid_env.files import UnsafeFolderError, trusted_file
from reachavoid_env.observations import GLOBAL, ObservationConfig, observe
from reachavoid_env.rules import unit_vectors

DEFAULT_OBSERVATION = ObservationConfig()

if TYPE_CHECKING:
    from policies.registry import NamedPolicy

SB3_PREFIX = "sb3:"
"""Policy names ``sb3:PATH`` are Stable-Baselines3 models saved at ``PATH``."""
SIDES = ("attackers", "defenders")
TRAINING_ATTRIBUTE = "reachavoid_training"
"""The attribute of a saved SB3 model holding how it was trained: a dict with
``action_repeat``, ``observation`` (the ``ObservationConfig``'s fields; absent: v0's
global observation), ``max_cycles`` (the time left's unit; absent: the scenario's
``max_steps``) and ``full_speed`` (absent: False), and, for the record, ``scenario``.
SB3 saves and loads an algorithm's plain attributes with the model."""

Predict = Callable[[np.ndarray], Any]


def training_record(observation: ObservationConfig, max_cycles: int | None = None,
                    **extra: Any) -> dict[str, Any]:
    """What ``TRAINING_ATTRIBUTE`` holds for a model trained on observations
    ``observation`` with episodes of ``max_cycles`` steps (``None``: the scenario's), and
    ``extra`` (``action_repeat``, ``full_speed``, ``scenario``)."""
    record = {"observation": asdict(observation), **extra}
    if max_cycles is not None:
        record["max_cycles"] = max_cycles
    return record


class ObservationPolicy:
    """A ``Policy`` for one side from ``predict``, a function of observations.

    ``predict`` maps a batch of observations ``(K, D)`` float32 (one row per live agent of
    ``side``, in name order; ``observation`` is their layout, ``reachavoid_env.observations``,
    the env's egocentric default unless given) to actions ``(K, 2)`` in ``[-1, 1]`` (a velocity as a
    fraction of the player's speed), as ``model.predict`` does. Every agent of the side
    shares it (parameter sharing). Actions are chosen at env steps ``0, k, 2k, ...``
    (``action_repeat = k``) and held in between. With ``full_speed`` every action is scaled
    to length 1 (a heading: the player runs at its full speed; a zero action stays zero),
    else clipped to ``[-1, 1]``. ``observation_size``, when given, is
    checked against each scenario at ``reset``. ``max_cycles`` is the time left's unit (the
    scenario's ``max_steps`` when ``None``).
    """

    def __init__(self, predict: Predict, side: str = "attackers", action_repeat: int = 1,
                 observation_size: int | None = None, label: str = "the learned policy",
                 observation: ObservationConfig = DEFAULT_OBSERVATION,
                 max_cycles: int | None = None, full_speed: bool = False) -> None:
        if side not in SIDES:
            raise ValueError(f"side: expected one of {SIDES}, got {side!r}")
        self.predict = predict
        self.side = side
        self.action_repeat = checks.integer(action_repeat, "action_repeat", 1, 1_000_000)
        self.observation_size = observation_size
        self.label = label
        self.observation = observation
        self.max_cycles = max_cycles
        self.full_speed = bool(full_speed)
        self._map = None
        self._max_cycles = 1
        self._held: dict[str, np.ndarray] = {}

    def check(self, scenario: Scenario) -> None:
        """``PolicyMismatch`` when the policy's observations do not fit ``scenario``."""
        size = self.observation.size(scenario.num_attackers, scenario.num_defenders)
        if self.observation_size is not None and self.observation_size != size:
            raise PolicyMismatch(
                f"{self.side}: {self.label} observes {self.observation_size} numbers; "
                f"{scenario.name!r} has {scenario.num_attackers} attackers and "
                f"{scenario.num_defenders} defenders ({size} numbers in its observation)")

    def reset(self, scenario: Scenario) -> None:
        self.check(scenario)
        self._map = scenario.map
        self._max_cycles = self.max_cycles or scenario.max_steps
        self._held = {}

    def act(self, state: GameState) -> dict[str, np.ndarray]:
        if self._map is None:
            raise RuntimeError("act: call reset(scenario) first")
        if self.side == "attackers":
            live = [name for name, on in zip(state.attacker_names, state.active_attackers,
                                             strict=True) if on]
        else:
            live = state.defender_names if state.active_attackers.any() else []
        if state.step % self.action_repeat == 0 or any(n not in self._held for n in live):
            self._held = self._decide(state, live)
        return {name: self._held[name] for name in live}

    def _decide(self, state: GameState, live: list[str]) -> dict[str, np.ndarray]:
        if not live:
            return {}
        observations = observe(state, self._map, self.observation, self._max_cycles)
        batch = np.stack([observations[name] for name in live])
        actions = np.asarray(self.predict(batch), dtype=np.float32).reshape(len(live), 2)
        actions = (unit_vectors(actions).astype(np.float32) if self.full_speed
                   else np.clip(actions, -1.0, 1.0))
        return dict(zip(live, actions, strict=True))


def check_model_file(path: str | Path, field: str) -> Path:
    """``path`` if it is a model file that can be read: a model file is code (loading one
    unpickles it, which runs whatever it holds), so it must be a file that only this user
    or root can change, in folders only their owner can write (``files.trusted_file``, the
    rule of the caches). ``ValueError`` naming ``field`` otherwise; nothing is read."""
    path = Path(path)
    if not path.is_file():
        raise ValueError(f"{field}: model {str(path)!r} is not a file")
    try:
        trusted_file(path)
    except (OSError, UnsafeFolderError) as err:
        reason = f"{err.filename}: {err.strerror}" if isinstance(err, OSError) else str(err)
        raise ValueError(f"{field}: model {str(path)!r} is not read: a model file is code, and "
                         f"others could change this one ({reason})") from None
    return path


def _stable_baselines3(field: str, what: str) -> Any:
    """The ``stable_baselines3`` module, or ``ValueError`` naming ``field`` when it (or one
    of its own imports, torch) cannot be imported."""
    try:
        import stable_baselines3
    except ImportError:
        raise ValueError(f"{field}: {what} needs Stable-Baselines3 (pip install "
                         "'reachavoid[rl]')") from None
    return stable_baselines3


def read_sb3(path: str | Path, field: str, algorithm: str = "PPO", **options: Any) -> Any:
    """The Stable-Baselines3 ``algorithm`` model saved at ``path``, on the CPU (``options``
    go to its ``load``): the file checked first (``check_model_file``), then loaded; a file
    SB3 cannot load, or one whose weights are not all finite, is a ``ValueError`` naming
    ``field``."""
    path = check_model_file(path, field)
    model_class = getattr(_stable_baselines3(field, repr(str(path))), algorithm, None)
    if model_class is None:
        raise ValueError(f"algorithm: {algorithm!r} is not a Stable-Baselines3 algorithm")
    try:
        model = model_class.load(path, device="cpu", **options)
    except Exception as err:  # SB3 raises many kinds on a foreign or damaged file
        first_line = str(err).splitlines()[0] if str(err) else type(err).__name__
        raise ValueError(f"{field}: cannot load {str(path)!r} as a Stable-Baselines3 "
                         f"{algorithm} model: {first_line}") from None
    for name, weights in model.policy.state_dict().items():
        if not weights.isfinite().all():
            raise ValueError(f"{field}: model {str(path)!r} has weights that are not finite "
                             f"({name})")
    return model


def load_sb3(path: str | Path, side: str = "attackers", action_repeat: int | None = None,
             algorithm: str = "PPO") -> ObservationPolicy:
    """The Stable-Baselines3 model saved at ``path`` (by ``algorithm``, a class of
    ``stable_baselines3``; read with ``read_sb3``) as a deterministic ``ObservationPolicy``
    for ``side``. ``action_repeat`` defaults to the one stored by the training examples
    (``TRAINING_ATTRIBUTE``), else 1; so does ``full_speed`` (else False)."""
    model = read_sb3(path, side, algorithm)
    trained = getattr(model, TRAINING_ATTRIBUTE, None) or {}
    shape = model.observation_space.shape
    if len(shape) != 1 or model.action_space.shape != (2,):
        raise ValueError(f"{side}: {str(path)!r} is not a policy of this game (observations "
                         f"{shape}, actions {model.action_space.shape})")
    return ObservationPolicy(lambda batch: model.predict(batch, deterministic=True)[0],
                             side=side,
                             action_repeat=action_repeat or trained.get("action_repeat", 1),
                             observation_size=shape[0], label=f"model {str(path)!r}",
                             observation=ObservationConfig(**trained["observation"])
                             if "observation" in trained else GLOBAL,
                             max_cycles=trained.get("max_cycles"),
                             full_speed=trained.get("full_speed", False))


def sb3_named_policy(side: str, spec: str) -> NamedPolicy:
    """The policy of the spec ``sb3:PATH`` (``policies.registry.SCHEMES``): built with
    ``load_sb3``'s ``action_repeat`` / ``algorithm`` options and checked against the
    scenario; ``ValueError`` naming ``side`` if ``PATH`` is not a file others cannot change
    (``check_model_file``) or Stable-Baselines3 does not import, before any work."""
    from policies.registry import NamedPolicy

    path = Path(spec[len(SB3_PREFIX):])
    if not path.is_file():
        raise ValueError(f"{side}: model {str(path)!r} (in {spec!r}) is not a file")
    check_model_file(path, side)
    _stable_baselines3(side, repr(spec))

    def build(scenario: Scenario, action_repeat: int | None = None,
              algorithm: str = "PPO") -> ObservationPolicy:
        policy = load_sb3(path, side, action_repeat, algorithm)
        policy.check(scenario)
        return policy

    return NamedPolicy(f"the Stable-Baselines3 model {path}", build)
