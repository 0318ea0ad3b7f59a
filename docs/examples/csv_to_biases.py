"""From a folder of measured CSV sweeps to the biases that tune the gyro, with a Bode plot.

Run it from the repository (or a copy of its ``examples/`` folder)::

    python docs/examples/csv_to_biases.py examples/measured/manifest.toml

The folder holds one CSV file per sweep (the toolkit's CSV format, docs/measured-data.md) and a
``manifest.toml`` saying at which biases they were measured. The script fits one
bias-dependent model to all sweeps, prints its modes at each measured bias, the biases that
make the two modes degenerate (inside ±10 V), and writes ``runs/csv-to-biases/fit.png``
(data as markers, model as lines). Copy it into a notebook cell by cell if you prefer.
"""

from __future__ import annotations

import sys
from pathlib import Path

from sysid_core import fit, predict_bias
from sysid_core.formats.manifest import load_data
from sysid_core.run.plots import fit_figure, save_figure

manifest = Path(sys.argv[1] if len(sys.argv) > 1 else "examples/measured/manifest.toml")

# 1. The measured sweeps, checked (complex values, frequencies, the rank condition (6)).
data = load_data(manifest)
print(f"{data.sizes['experiment']} sweeps at biases {data['bias'].values.tolist()} V")

# 2. One model for all of them (the paper's eq. 8, output dynamics, polynomial order 1).
model = fit(data, "act")  # order 2, bias-dependent constant term, least squares
for bias in data["bias"].values:
    modes = model.modal(bias)
    print(
        f"at {bias.tolist()} V: modes {modes.frequencies_hz.round(3).tolist()} Hz, "
        f"split {modes.split_hz * 1e3:.1f} mHz"
    )

# 3. The biases that make the modes degenerate, inside the DAC's range.
tuned = predict_bias(model, "degenerate", bias_limits=(-10.0, 10.0))
setting = ", ".join(f"{e} = {b:.4f} V" for e, b in zip(model.electrodes, tuned.bias, strict=True))
print(f"set {setting}: both modes at {tuned.frequency_hz:.3f} Hz (predicted, one iteration)")
region = tuned.confidence  # how sure: 95 % intervals from the fit's covariance
if region is not None:
    for e, (low, high) in zip(model.electrodes, region.bias_ci, strict=True):
        print(f"  {e}: {low:.4f} .. {high:.4f} V (95 %)")
    print(f"  split at that bias: {region.split_ci_hz[1] * 1e3:.2f} mHz or less (95 %)")

# 4. Data against model (markers: data, lines: model), for the lab book.
figure = fit_figure(data, model, title=f"{manifest.name}: data (markers) and model (lines)")
print("plot:", save_figure(figure, Path("runs") / "csv-to-biases" / "fit.png"))
