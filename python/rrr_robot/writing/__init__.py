"""The writing task (paper section V), above the simulation layer.

letters (text to pen strokes, Hershey fonts), writing_path (C2 curves through the strokes),
trajectory (timing law, reference tip and joint motion), scenarios (controller configurations,
TOML), job (the task end to end: reference, co-simulations, metrics, outputs), plots (the
figures), references (Pinocchio's inverse dynamics, the numeric reference of Fig 6).
"""
