"""Study: why Algorithm 1's certified guarantee breaks, and what margin would make it hold.

Two parts (BENCHMARKS.md, "The guarantee"; the certificate rule itself now lives in
the policy, ``policies/certificate.py``, and ``benchmarks/guarantee.py --margin-cells C``
measures it):

``tubes``: a grid-refinement study. The 1 vs 1 tube at ``--grids1`` against a finer
reference (``--reference1``), and the 2 vs 1 tube at ``--grids2`` (all built on the
reference-grade 45^4 1 vs 1 tube) against ``--reference2``, compared by interpolation
at random states of the map of ``--scenario`` (attackers outside the target, uncaptured). Per grid:
the largest and 99th-percentile difference, the *margin* (the largest coarse value at a
state where the reference says the attacker side wins: the slack a certificate
``value > margin`` needs on this sample), and the share of defender wins (value > 0) it
would give up.

``episodes``: the episodes of ``benchmarks/guarantee.py`` on the paper map (same
configurations, seeds and attacker order), recorded, with the defenders reading the tubes
as the paper does (``--margin-cells 0``, default). For each episode whose guarantee
broke, the first broken promise is traced: the assigned game (a defender and its one or
two attackers) of the decision before the fall whose value reached <= 0 or whose attacker
arrived, and the run of steps in which that defender had held that game. The cause is
classified in order:

1. ``tube error``: at the start of the run the finer tubes (``--fine1/--fine2``) say the
   attacker side wins (value <= 0): the coarse certificate was wrong from the start;
2. ``time step``: replayed alone from the run's start (the same attacker actions, the
   defender's control recomputed every ``dt / 10``), the defender now wins;
3. ``control``: replayed alone with the finer tubes' control at ``dt``, it wins (the
   coarse gradient steered it wrong; ``kink`` counts steps where its heading turned by
   more than 90 degrees);
4. ``within the finer tube's error``: the finer value at the start is positive but no
   larger than the finer tube's own measured error margin (``--fine-margin``, from the
   ``tubes`` study), so the finer tube cannot tell either;
5. ``unexplained`` otherwise.

"Wins" in a replay: no attacker of the game arrives and the finer tube's value of the
game stays > 0 while the recorded attacker actions last. Every violating episode is also
replayed whole with unassigned defenders standing still (``idle="stand"``) to show
whether the shadowing of unassigned defenders matters.

    python benchmarks/guarantee_causes.py tubes [--grids1 25 31 45] [--reference1 81] \\
        [--json benchmarks/results/guarantee_causes.json]
    python benchmarks/guarantee_causes.py episodes --grid1 25 --grid2 13 --episodes 20
"""

from __future__ import annotations

import argparse
import itertools
from dataclasses import dataclass, field, replace

import numpy as np
from result_file import write_result
from tqdm import tqdm

import reachavoid_env
from policies import HJAttacker, HJDefenderPolicy, RandomAttacker, ShortestPathAttacker
from policies.tube_states import pair_states, triple_states
from policies.tubes import tube_1v1
from reachavoid.rollout import CertifiesCaptures, run_episode
from reachavoid_env import AttackerStatus, GameState, Overlay, Scenario, merged_overlay
from solvers.assignment import Assignment
from solvers.hj import ValueFunction, solve_2v1

CONFIGS = ((4, 2), (6, 2), (8, 4))
CAUSES = ("tube error", "time step", "control", "within the finer tube's error", "unexplained",
          "no broken game")


@dataclass(frozen=True)
class Tubes:
    """A 1 vs 1 and a 2 vs 1 tube, and the value of any defender's game with them."""

    vf11: ValueFunction
    vf21: ValueFunction

    def game_value(self, attackers: np.ndarray, defender: np.ndarray) -> float:
        """Value of one defender's game against one or two attackers ``(k, 2)`` as the
        MIP reads it (> 0: it may keep the game): the 1 vs 1 value, and for two attackers
        also the 2 vs 1 value ((c4) and (c5): the smallest of the three)."""
        alone = float(self.vf11.value(pair_states(attackers, defender[None])).min())
        if len(attackers) == 1:
            return alone
        return min(alone, float(self.vf21.value(triple_states(
            attackers, np.array([[0, 1]]), defender[None]))[0, 0]))

    def pair_exceeds_alone(self, attackers: np.ndarray, defender: np.ndarray) -> bool:
        """For two attackers: is the 2 vs 1 value above a 1 vs 1 value that is <= 0
        (inconsistent tubes: the pair game says it wins, a lone game says it loses)?"""
        if len(attackers) == 1:
            return False
        alone = float(self.vf11.value(pair_states(attackers, defender[None])).min())
        pair = float(self.vf21.value(triple_states(attackers, np.array([[0, 1]]),
                                                   defender[None]))[0, 0])
        return alone <= 0 < pair

    def heading(self, attackers: np.ndarray, defender: np.ndarray) -> np.ndarray:
        """The defender's optimal heading in that game (towards the nearer attacker where
        the gradient vanishes, as the policy does)."""
        x = np.concatenate([*attackers, defender])[None]
        vf = self.vf11 if len(attackers) == 1 else self.vf21
        control = vf.defender_control(x)[0]
        if np.linalg.norm(control) > 0:
            return control
        gaps = attackers - defender
        nearest = gaps[int(np.argmin(np.linalg.norm(gaps, axis=1)))]
        return nearest / max(np.linalg.norm(nearest), 1e-12)


class Recorder:
    """Wraps a policy and keeps every state it saw, its actions and (defenders) its
    assignment; behaves exactly as the wrapped policy."""

    def __init__(self, policy: object) -> None:
        self.policy = policy
        self.states: list[GameState] = []
        self.actions: list[dict[str, np.ndarray]] = []
        self.assignments: list[Assignment | None] = []

    def reset(self, scenario: Scenario) -> None:
        self.states, self.actions, self.assignments = [], [], []
        self.policy.reset(scenario)

    def act(self, state: GameState) -> dict[str, np.ndarray]:
        actions = self.policy.act(state)
        self.states.append(state)
        self.actions.append(actions)
        self.assignments.append(getattr(self.policy, "last_assignment", None))
        return actions

    @property
    def guaranteed_captures(self) -> int | None:
        certifies = isinstance(self.policy, CertifiesCaptures)
        return self.policy.guaranteed_captures if certifies else None

    @property
    def nominal_captures(self) -> int | None:
        certifies = isinstance(self.policy, CertifiesCaptures)
        return self.policy.nominal_captures if certifies else None

    def overlay(self) -> Overlay | None:
        return merged_overlay(self.policy)


@dataclass(frozen=True)
class Episode:
    """One recorded episode: per decision step the state, both sides' actions and the
    assignment."""

    states: list[GameState]
    attacker_actions: list[dict[str, np.ndarray]]
    defender_actions: list[dict[str, np.ndarray]]
    assignments: list[Assignment | None]
    final: GameState

    @classmethod
    def of(cls, attackers: Recorder, defenders: Recorder, final: GameState) -> Episode:
        return cls(defenders.states, attackers.actions, defenders.actions,
                   defenders.assignments, final)


@dataclass
class Break:
    """The first broken promise of an episode: defender ``defender`` held attackers
    ``attackers`` from step ``start`` (value ``value_start`` on the coarse tubes,
    ``fine_start`` on the fine ones) and lost that game at step ``step``."""

    episode: str
    step: int
    defender: int = -1
    attackers: tuple[int, ...] = ()
    start: int = -1
    value_start: float = np.nan
    fine_start: float = np.nan
    cause: str = "no broken game"
    kinks: int = 0
    replays: dict[str, bool] = field(default_factory=dict)
    standing_violates: bool | None = None


def _groups(assignment: Assignment) -> list[tuple[int, tuple[int, ...]]]:
    return [(j, mine) for j, mine in enumerate(assignment.by_defender) if mine]


def first_break(rec: Episode, guarantees: np.ndarray, coarse: Tubes) -> tuple[int, int,
                                                                                tuple[int, ...]]:
    """``(step, defender, attackers)`` of the first broken promise (defender -1: none
    found): the game of the previous decision that was lost at ``step``."""
    falls = np.flatnonzero(guarantees < np.maximum.accumulate(guarantees))
    candidates = [int(falls[0])] if falls.size else []
    statuses = [s.attacker_status for s in [*rec.states, rec.final]]
    for t in range(1, len(statuses)):
        arrived = [i for i, st in enumerate(statuses[t]) if st == AttackerStatus.ARRIVED
                   and statuses[t - 1][i] != AttackerStatus.ARRIVED]
        if arrived and rec.assignments[t - 1] is not None \
                and any(rec.assignments[t - 1].defender_of(i) is not None for i in arrived):
            candidates.append(t)
            break
    if not candidates:
        return -1, -1, ()
    t = min(candidates)
    state, previous = [*rec.states, rec.final][t], rec.assignments[t - 1]
    for j, mine in _groups(previous):
        status = [state.attacker_status[i] for i in mine]
        if AttackerStatus.ARRIVED in status:
            return t, j, mine
        live = [i for i, s in zip(mine, status, strict=True) if s == AttackerStatus.ACTIVE]
        if live and coarse.game_value(state.attacker_positions[live],
                                      state.defender_positions[j]) <= 0:
            return t, j, mine
    return t, -1, ()


def replay(rec: Episode, brk: Break, control: Tubes, judge: Tubes, scenario: Scenario,
           substeps: int = 1) -> bool:
    """Does the defender win its game alone from the run's start against the recorded
    attacker actions, steering by ``control`` every ``dt / substeps``? Judged by arrival
    and by ``judge``'s value staying > 0."""
    s, j, mine = brk.start, brk.defender, brk.attackers
    start = rec.states[s]
    game = replace(scenario.with_starts(start.attacker_positions[list(mine)],
                                        start.defender_positions[[j]]),
                   dt=scenario.dt / substeps, max_steps=(len(rec.states) - s) * substeps + 1)
    env = reachavoid_env.parallel_env(scenario=game)
    env.reset(seed=0)
    names = [f"attacker_{i}" for i in mine]
    for actions in rec.attacker_actions[s:]:
        for _ in range(substeps):
            state = env.unwrapped.game_state()
            live = np.flatnonzero(state.active_attackers)
            if AttackerStatus.ARRIVED in state.attacker_status:
                return False
            if len(live) == 0 or not env.agents:
                return True
            attackers, defender = state.attacker_positions[live], state.defender_positions[0]
            if judge.game_value(attackers, defender) <= 0:
                return False
            step = {f"attacker_{k}": actions.get(name, np.zeros(2, np.float32))
                    for k, name in enumerate(names) if f"attacker_{k}" in env.agents}
            step["defender_0"] = control.heading(attackers, defender).astype(np.float32)
            env.step(step)
    return AttackerStatus.ARRIVED not in env.unwrapped.game_state().attacker_status


def kinks(rec: Episode, brk: Break) -> int:
    """Steps of the run at which the defender's heading turned by more than 90 degrees."""
    name = f"defender_{brk.defender}"
    headings = [a[name] for a in rec.defender_actions[brk.start:brk.step] if name in a]
    return int(sum(np.dot(u, v) < 0 for u, v in itertools.pairwise(headings)))


def classify(rec: Episode, result, coarse: Tubes, fine: Tubes, scenario: Scenario,
             label: str, fine_margin: tuple[float, float]) -> Break:
    t, j, mine = first_break(rec, np.asarray(result.guarantees), coarse)
    brk = Break(label, t)
    if j < 0:
        return brk
    s = t - 1
    while s > 0 and rec.assignments[s - 1] is not None \
            and rec.assignments[s - 1].by_defender[j] == mine:
        s -= 1
    start = rec.states[s]
    brk.defender, brk.attackers, brk.start = j, mine, s
    attackers, defender = start.attacker_positions[list(mine)], start.defender_positions[j]
    brk.value_start = coarse.game_value(attackers, defender)
    brk.fine_start = fine.game_value(attackers, defender)
    brk.kinks = kinks(rec, brk)
    brk.replays = {"same": replay(rec, brk, coarse, fine, scenario),
                   "dt/10": replay(rec, brk, coarse, fine, scenario, substeps=10),
                   "fine control": replay(rec, brk, fine, fine, scenario)}
    if brk.fine_start <= 0:
        brk.cause = "tube error"
    elif brk.replays["dt/10"]:
        brk.cause = "time step"
    elif brk.replays["fine control"]:
        brk.cause = "control"
    elif brk.fine_start <= fine_margin[len(brk.attackers) - 1]:
        brk.cause = "within the finer tube's error"
    else:
        brk.cause = "unexplained"
    return brk


def episodes(args: argparse.Namespace) -> None:
    base = reachavoid_env.builtin_scenario("paper_2v1")
    coarse = Tubes(*_tubes(base, args.grid1, args.grid2))
    fine11 = tube_1v1(base, args.fine1)
    # The same 6-D grid: keep the coarse 2 vs 1 tube rather than solve it again on the
    # finer 1 vs 1 tube (a 30^6 solve is minutes and gigabytes).
    fine21 = coarse.vf21 if args.fine2 == args.grid2 else solve_2v1(
        base.map, fine11, grid_points=args.fine2)
    fine = Tubes(fine11, fine21)
    defenders = Recorder(HJDefenderPolicy(coarse.vf11, coarse.vf21,
                                          margin_cells=args.margin_cells))
    standing = HJDefenderPolicy(coarse.vf11, coarse.vf21, idle="stand",
                                margin_cells=args.margin_cells)
    breaks: list[Break] = []
    total = 0
    for m, n in CONFIGS:
        env = reachavoid_env.parallel_env(scenario=base.with_players(m, n))
        # As benchmarks/guarantee.py: one attacker object per kind across all episodes.
        attackers = {"shortest-path": ShortestPathAttacker(), "random": RandomAttacker(0),
                     "hj": HJAttacker(coarse.vf11)}
        for label, attacker in attackers.items():
            recorded = Recorder(attacker)
            for seed in tqdm(range(args.episodes), desc=f"{m}v{n} {label}", leave=False):
                total += 1
                result = run_episode(env, recorded, defenders, seed=seed)
                if result.guarantee_violations == 0:
                    continue
                brk = classify(Episode.of(recorded, defenders, env.unwrapped.game_state()),
                               result, coarse, fine, env.unwrapped.scenario,
                               f"{m}v{n} {label} seed {seed}", args.fine_margin)
                if label != "random":  # the random stream would differ in a rerun
                    again = run_episode(env, attacker, standing, seed=seed)
                    brk.standing_violates = again.guarantee_violations > 0
                breaks.append(brk)
    _print_breaks(args, breaks, total)


def _tubes(scenario: Scenario, grid1: int, grid2: int) -> tuple[ValueFunction, ValueFunction]:
    vf11 = tube_1v1(scenario, grid1)
    return vf11, solve_2v1(scenario.map, vf11, grid_points=grid2)


def _print_breaks(args: argparse.Namespace, breaks: list[Break], total: int) -> None:
    print(f"tubes {args.grid1}^4 / {args.grid2}^6, finer tubes {args.fine1}^4 / "
          f"{args.fine2}^6 (error margins {args.fine_margin[0]:g} / {args.fine_margin[1]:g}): "
          f"{len(breaks)} of {total} episodes violated")
    print("| episode | broken game | from step | lost at | V coarse | V fine | replay same "
          "/ dt/10 / fine control | kinks | stand: violated | cause |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    for b in breaks:
        game = (f"D{b.defender} vs " + "+".join(f"A{i}" for i in b.attackers)) \
            if b.defender >= 0 else "-"
        won = "/".join("won" if b.replays.get(k) else "lost"
                       for k in ("same", "dt/10", "fine control")) if b.replays else "-"
        stand = "-" if b.standing_violates is None else ("yes" if b.standing_violates else "no")
        print(f"| {b.episode} | {game} | {b.start} | {b.step} | {b.value_start:+.4f} | "
              f"{b.fine_start:+.4f} | {won} | {b.kinks} | {stand} | {b.cause} |")
    print("\n| cause | episodes |")
    print("|---|---|")
    for cause in CAUSES:
        print(f"| {cause} | {sum(b.cause == cause for b in breaks)} |")
    print(f"| all | {len(breaks)} / {total} |")
    starts = np.array([b.value_start for b in breaks if b.defender >= 0])
    if len(starts):
        print(f"coarse value at the start of the broken game: max {starts.max():+.4f}, "
              f"median {np.median(starts):+.4f}")


def _sample_states(game_map, players: int, count: int, capture_radius: float,
                   rng: np.random.Generator) -> np.ndarray:
    """Random states ``(count, 2 players)``: everyone in free space, attackers (all but
    the last player) outside the target and uncaptured."""
    xmin, xmax, ymin, ymax = game_map.domain
    kept = []
    while sum(len(k) for k in kept) < count:
        points = rng.uniform([xmin, ymin], [xmax, ymax], size=(4 * count, players, 2))
        ok = np.all(game_map.obstacle_signed_distance(points.reshape(-1, 2)).reshape(
            -1, players) > 0, axis=1)
        attackers, defender = points[:, :-1], points[:, -1:]
        ok &= np.all(game_map.target_signed_distance(attackers.reshape(-1, 2)).reshape(
            len(points), -1) > 0, axis=1)
        ok &= np.all(np.linalg.norm(attackers - defender, axis=-1) > capture_radius, axis=1)
        kept.append(points[ok].reshape(int(ok.sum()), -1))
    return np.concatenate(kept)[:count]


def _compare(vf: ValueFunction, reference: ValueFunction, states: np.ndarray,
             figures: dict[str, float], game: str = "") -> str:
    """The table row of ``vf`` against ``reference``; its figures go into ``figures``
    (keys suffixed ``game``, by grid)."""
    coarse, ref = vf.value(states), reference.value(states)
    diff = np.abs(coarse - ref)
    false_wins = coarse[(ref <= 0)]
    margin = max(float(false_wins.max(initial=-np.inf)), 0.0)
    wins = coarse > 0
    lost = np.mean(coarse[wins] <= margin) if wins.any() else 0.0
    disagree = np.mean((coarse > 0) != (ref > 0))
    spacing = vf.grid.spacing[0]
    grid = vf.grid.shape[0]
    figures |= {f"max_abs_diff{game}.{grid}": float(diff.max()),
                f"p99_abs_diff{game}.{grid}": float(np.percentile(diff, 99)),
                f"sign_disagrees_percent{game}.{grid}": 100 * float(disagree),
                f"margin{game}.{grid}": margin,
                f"wins_given_up_percent{game}.{grid}": 100 * float(lost)}
    return (f"| {vf.grid.shape[0]} | {spacing:.4f} | {diff.max():.4f} | "
            f"{np.percentile(diff, 99):.4f} | {disagree:.2%} | {margin:.4f} "
            f"({margin / spacing:.2f} h) | {lost:.1%} |")


def tubes(args: argparse.Namespace) -> None:
    figures: dict[str, float] = {}
    _tubes(args, figures)
    if args.json:
        write_result(args.json, "guarantee_causes", figures, {
            name: what + " (_2v1: the 2 vs 1 game), by grid" for name, what in (
                ("max_abs_diff", "largest value error against the reference tube"),
                ("p99_abs_diff", "99th percentile of the value error"),
                ("sign_disagrees_percent", "states where the signs disagree, percent"),
                ("margin", "the slack a certificate needs on this sample (map units)"),
                ("wins_given_up_percent", "defender wins at or below that margin, percent"))
            for name in (name, name + "_2v1")})


def _tubes(args: argparse.Namespace, figures: dict[str, float]) -> None:
    base = reachavoid_env.builtin_scenario(args.scenario)
    rng = np.random.default_rng(args.seed)
    header = ("| grid | spacing h | max abs diff | p99 abs diff | sign disagrees | margin "
              "| wins given up |\n|---|---|---|---|---|---|---|")
    reference1 = tube_1v1(base, args.reference1)
    states = _sample_states(base.map, 2, args.states, base.capture_radius, rng)
    print(f"1 vs 1 against {args.reference1}^4, {len(states)} random states")
    print(header)
    for grid in args.grids1:
        print(_compare(tube_1v1(base, grid), reference1, states, figures), flush=True)
    if not args.grids2:
        return
    vf11 = tube_1v1(base, args.base1)
    reference2 = solve_2v1(base.map, vf11, grid_points=args.reference2)
    states = _sample_states(base.map, 3, args.states, base.capture_radius, rng)
    print(f"\n2 vs 1 against {args.reference2}^6 (all on the {args.base1}^4 1 vs 1 tube), "
          f"{len(states)} random states")
    print(header)
    for grid in args.grids2:
        print(_compare(solve_2v1(base.map, vf11, grid_points=grid), reference2, states,
                       figures, "_2v1"), flush=True)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    sub = parser.add_subparsers(dest="study", required=True)
    t = sub.add_parser("tubes", help="grid-refinement study of the tubes")
    t.add_argument("--grids1", type=int, nargs="+", default=[25, 31, 45])
    t.add_argument("--reference1", type=int, default=81)
    t.add_argument("--base1", type=int, default=45, help="1 vs 1 tube under every 2 vs 1")
    t.add_argument("--grids2", type=int, nargs="*", default=[13, 15, 20],
                   help="2 vs 1 grids to compare (none: the 1 vs 1 study alone)")
    t.add_argument("--scenario", default="paper_2v1",
                   help="whose map, speeds and capture radius (e.g. paper_6v4_equal)")
    t.add_argument("--reference2", type=int, default=30)
    t.add_argument("--states", type=int, default=20000)
    t.add_argument("--seed", type=int, default=0)
    t.add_argument("--json", help="write the result record (benchmarks/result_file.py) here")
    e = sub.add_parser("episodes", help="classify every violating episode")
    e.add_argument("--grid1", type=int, default=25)
    e.add_argument("--grid2", type=int, default=13)
    e.add_argument("--fine1", type=int, default=45)
    e.add_argument("--fine2", type=int, default=30)
    e.add_argument("--episodes", type=int, default=20, help="per configuration and attacker")
    e.add_argument("--fine-margin", type=float, nargs=2, default=[0.0105, 0.025],
                   metavar=("M11", "M21"),
                   help="measured error margins of the finer 1 vs 1 and 2 vs 1 tubes (the "
                        "tubes study: 45^4 against 81^4; 20^6 against 30^6, a lower bound "
                        "for 30^6)")
    e.add_argument("--margin-cells", type=float, default=0.0,
                   help="the defenders' certificate margin (default 0: the paper's reading, "
                        "whose breaks the study classifies)")
    args = parser.parse_args()
    {"tubes": tubes, "episodes": episodes}[args.study](args)


if __name__ == "__main__":
    main()
