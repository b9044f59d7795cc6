"""Training, in one place: the training views with named scripted policies (``views``: the
factories behind the Gymnasium / PettingZoo ids that ``reachavoid_env.training_ids``
registers), the scripts' shared flags (``flags``), the start curriculum (``curriculum``),
self-play with past policies (``self_play``), the BenchMARL task (``benchmarl_task``) and
MAPPO experiment (``benchmarl_experiment``), RLlib's PPO on the attackers (``rllib``), the
attacker-team recipe (``recipe``: flags in ``config``, the warm start in ``cloning``, PPO's
callbacks in ``callbacks``, the evaluation in ``teams``), the one-attacker recipe
(``single``), the defenders' MAPPO recipe (``mappo``) and the best response to a defender
(``exploit``). ``examples/`` hold short scripts that run these. torch, Stable-Baselines3,
TorchRL, BenchMARL and Ray are imported by the modules that use them alone, so importing this
package (or ``reachavoid``) loads none of them."""
