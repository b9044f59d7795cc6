"""Defender and attacker policies (design.md section 3)."""
