"""MAPPO on the game with BenchMARL: attackers and defenders each learn a shared policy, or
the attackers alone learn against scripted defenders.

Needs the ``benchmarl`` extra in a virtual environment of its own (BenchMARL pins
torchrl < 0.12): ``pip install -e '.[benchmarl]'``. ``--task game`` (the default) is
``reachavoid_env.integrations.benchmarl.ReachAvoidTask.REACH_AVOID``, both teams learning;
``--task attackers`` is ``reachavoid.training.benchmarl_task.ScriptedDefendersTask.ATTACKERS``, the
attackers of ``--envs`` copies stepped together learning against ``--defenders`` (``hj`` on
``--grid1`` / ``--grid2`` tubes by default):

    python examples/benchmarl_mappo.py --scenario paper_2v1 --frames 60000 --out runs/benchmarl
    python examples/benchmarl_mappo.py --task attackers --scenario paper_6v2 --envs 16 \
        --frames 200000 --out runs/benchmarl_attackers

BenchMARL writes its logs (CSV) and JSON results under ``--out``; the script prints each
group's mean losses of every iteration (``group, loss_objective x, loss_critic y, ...``).
``--batch`` must be a multiple of ``--envs`` with ``--task attackers``. The experiment is
``reachavoid.training.benchmarl_experiment`` (``MappoSettings``, ``run``).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

from reachavoid.training.benchmarl_experiment import TASKS, MappoSettings, run
from reachavoid.training.flags import (
    DefenderFields,
    config_parser,
    defender_options,
    scenario_field,
)
from reachavoid_env.checks import FieldError


@dataclass
class Config(DefenderFields):
    scenario: str = scenario_field(MappoSettings.scenario)
    task: str = field(default=MappoSettings.task, metadata={
        "choices": TASKS, "help": "game: both teams learn; attackers: the attackers learn "
                                  "against scripted --defenders"})
    envs: int = field(default=MappoSettings.envs, metadata={
        "help": "copies stepped together (--task attackers)"})
    max_cycles: int = field(default=MappoSettings.max_cycles, metadata={
        "help": "steps per episode"})
    frames: int = field(default=MappoSettings.frames, metadata={
        "help": "total env steps (a batched step counts one per copy)"})
    batch: int = field(default=MappoSettings.batch, metadata={"help": "env steps per iteration"})
    shaping: float = field(default=MappoSettings.shaping, metadata={
        "help": "weight of the progress reward"})
    seed: int = field(default=MappoSettings.seed, metadata={"help": "BenchMARL's seed"})
    out: Path = field(default=MappoSettings.out, metadata={
        "help": "BenchMARL's logs and results"})


def settings(config: Config) -> MappoSettings:
    """The experiment's settings (``checks.FieldError`` naming a bad field)."""
    return MappoSettings(
        task=config.task, scenario=config.scenario, defenders=config.defenders,
        defender_options=defender_options(config), envs=config.envs,
        max_cycles=config.max_cycles, frames=config.frames, batch=config.batch,
        shaping=config.shaping, seed=config.seed, out=config.out)


def main(config: Config) -> None:
    """Runs the experiment; prints the per-iteration losses of each group."""
    _, rows = run(settings(config))
    for row in rows:
        print(", ".join(f"{key} {value:.4g}" if isinstance(value, float) else str(value)
                        for key, value in row.items()), flush=True)


if __name__ == "__main__":
    parser = config_parser(Config, __doc__.split("\n\n")[0])
    config = Config(**vars(parser.parse_args()))
    try:
        settings(config)
    except FieldError as error:
        parser.error(error.renamed("--" + error.field.replace("_", "-")))
    main(config)
