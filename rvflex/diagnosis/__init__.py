"""Sim-to-real gap diagnosis: bench data I/O, gap localisation, effect library, fitting, report, self-check."""
