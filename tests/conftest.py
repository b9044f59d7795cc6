"""Test-wide settings: pygame draws offscreen (PettingZoo's render_test opens "human")."""

import os

os.environ.setdefault("SDL_VIDEODRIVER", "dummy")
os.environ.setdefault("SDL_AUDIODRIVER", "dummy")
