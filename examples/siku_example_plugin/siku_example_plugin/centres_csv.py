"""A writer: element centres and declared per-element fields as CSV rows (the plugin guide's
"Writers" section shows this file)."""
import csv
from pathlib import Path

import numpy as np

from siku_core.geometry.quat import latlon_of
from siku_core.interfaces import Writer
from siku_core.run.outputs import partial_path, publish, settle

MARK = "# siku centres_csv"  # the first line: how owns() knows the file


class CentresCSV(Writer):
    """Element centres and declared per-element fields, one row per element and snapshot."""

    name = "centres_csv"
    appends = True  # on a restart, open() continues its own file

    def open(self, ctx):
        self.target = Path(self.path)
        self.fields = sorted(ctx.field_catalogue())
        self.published = ctx.restarted_from is not None and self.owns(self.target)
        if self.published:  # a restart continues its own file
            self.file = open(self.target, "a", newline="")
            self.out = csv.writer(self.file)
            return
        # built aside, put in place with its first snapshot: an old file given to --overwrite
        # stays whole until then, and a run stopped before it leaves nothing
        self.partial = partial_path(self.target)
        self.replace = self.target.exists()  # the engine allowed it (--overwrite)
        self.file = open(self.partial, "x", newline="")
        self.out = csv.writer(self.file)
        units = [ctx.field_catalogue()[k][0] for k in self.fields]
        self.file.write(MARK + "\n")
        self.out.writerow(["time [s]", "element", "lat [deg]", "lon [deg]",
                           *(f"{k} [{u}]" for k, u in zip(self.fields, units))])

    def write_state(self, ctx):
        if self.published and ctx.step_index == ctx.restarted_from:
            return  # a restart: this snapshot is already in the file
        lat, lon = np.degrees(latlon_of(ctx.state.q))
        values = ctx.element_fields()
        for i in range(ctx.state.n):
            self.out.writerow([ctx.time, i, lat[i], lon[i],
                               *(values[k][i] for k in self.fields)])
        self.file.flush()
        if not self.published:
            publish(self.partial, self.target, replace=self.replace)
            self.published = True

    def _discard(self):  # siku_core.run.outputs.settle: no snapshot was written
        self.partial.unlink(missing_ok=True)

    def close(self, ctx):
        self.file.close()
        settle(self)

    @classmethod
    def owns(cls, path):
        try:
            with open(path, encoding="utf-8") as f:
                return f.readline().rstrip("\n") == MARK
        except (OSError, UnicodeDecodeError):
            return False
