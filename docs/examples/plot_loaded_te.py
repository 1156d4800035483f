"""
Loaded transmission error of the RV-40E
=======================================

The rigid RV-40E with seed 001's Table 2 errors at its rated 412 N·m, one output revolution at
256 positions: TE (arcsec) against the output angle, the mean wind-up, and the strongest orders.
"""

import matplotlib.pyplot as plt

import rvflex

spec = rvflex.load_reducer("rv40e")
errors = rvflex.load_errors("rv40e_seed001", spec)
result = rvflex.run(rvflex.LoadedTE(spec, errors, load_Nm=412.0, positions_per_rev=256))

m = result.metrics
print(f"TE peak-to-peak {m.te_pp_arcsec:.2f}″, mean wind-up {m.mean_windup_arcsec:.1f}″")
print("strongest orders:", ", ".join(f"{o}: {a:.2f}″" for o, a in m.orders[:4]))

fig, (ax_te, ax_orders) = plt.subplots(1, 2, figsize=(10, 4), layout="constrained")
result.plot(ax_te)
result.plot_orders(ax_orders)

# %%
# The same data, labelled: a tidy table with the unit in each column name.
result.to_dataframe().head()
