"""Training attacker teams: the team recipe (``recipe``: flags in ``config``, the warm
start in ``cloning``, PPO's callbacks in ``callbacks``, the evaluation in ``teams``) and the
best response to a defender (``exploit``). torch and Stable-Baselines3 are imported by these
modules alone, so importing this package (or ``reachavoid``) loads neither."""
