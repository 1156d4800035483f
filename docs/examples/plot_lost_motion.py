"""
Torsional hysteresis: lost motion and stiffness
===============================================

The catalogue test on the rigid RV-40E (input locked, output torque 0 → +T_r → −T_r → 0, 80
steps): lost motion, hysteresis loss, torsional stiffness and backlash, and the loop.
"""

import matplotlib.pyplot as plt

import rvflex

spec = rvflex.load_reducer("rv40e")
result = rvflex.run(rvflex.LostMotion(spec, steps=80))
for name, value in result.metrics_dict().items():
    print(f"{name:36s} {value:.4g}")

fig, ax = plt.subplots(figsize=(6, 4), layout="constrained")
result.plot(ax)
