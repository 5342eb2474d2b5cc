"""A writer: element centres and declared per-element fields as CSV rows (the plugin guide's
"Writers" section shows this file)."""
import csv

import numpy as np

from siku_core.geometry.quat import latlon_of
from siku_core.interfaces import Writer


class CentresCSV(Writer):
    """Element centres and declared per-element fields, one row per element and snapshot."""

    name = "centres_csv"
    appends = True  # on a restart, open() continues its own file

    def open(self, ctx):
        mode = "a" if ctx.restarted_from is not None else "x"  # never replace a file
        self.file = open(self.path, mode, newline="")
        self.out = csv.writer(self.file)
        self.fields = sorted(ctx.field_catalogue())
        if mode == "x":
            units = [ctx.field_catalogue()[k][0] for k in self.fields]
            self.out.writerow(["time [s]", "element", "lat [deg]", "lon [deg]",
                               *(f"{k} [{u}]" for k, u in zip(self.fields, units))])

    def write_state(self, ctx):
        if ctx.step_index == ctx.restarted_from:
            return  # a restart: this snapshot is already in the file
        lat, lon = np.degrees(latlon_of(ctx.state.q))
        values = ctx.element_fields()
        for i in range(ctx.state.n):
            self.out.writerow([ctx.time, i, lat[i], lon[i],
                               *(values[k][i] for k in self.fields)])
        self.file.flush()

    def close(self, ctx):
        self.file.close()
