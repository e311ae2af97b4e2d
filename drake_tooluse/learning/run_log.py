"""A run's logs (`OUT/logs/`): SB3's logger writing progress.csv and TensorBoard events so that
a resumed run's logs are those of one that never stopped. On a resume the CSV keeps the rows up
to the checkpoint (a killed session's later rows, and a row cut by the kill, are dropped), the
TensorBoard writer purges the events after it, and the counters SB3 restarts each session
(`time/iterations`, `time/time_elapsed`) carry on.
"""

from __future__ import annotations

import csv
from pathlib import Path

from stable_baselines3.common.logger import (
    Figure,
    FormatUnsupportedError,
    HParam,
    Image,
    KVWriter,
    Logger,
    TensorBoardOutputFormat,
    Video,
    filter_excluded_keys,
)
from torch.utils.tensorboard import SummaryWriter

from drake_tooluse.files import atomic_write_text
from drake_tooluse.learning.sb3_state import adopt_summary_writer

STEPS_KEY = "time/total_timesteps"  # every row SB3 dumps has it

_UNSUPPORTED = ((Video, "video"), (Figure, "figure"), (Image, "image"), (HParam, "hparam"))


def kept_rows(path: Path, until: int) -> tuple[list[str], list[str], int | None]:
    """The header and the complete rows of an SB3 progress.csv up to `until` steps (a row cut
    by a kill is dropped), and the most steps a dropped row reached."""
    lines = path.read_text().splitlines(keepends=True)
    if not lines or not lines[0].endswith("\n"):
        return [], [], None
    header = next(csv.reader([lines[0]]))
    column = header.index(STEPS_KEY) if STEPS_KEY in header else None
    kept, dropped = [], None
    for line in lines[1:]:
        fields = next(csv.reader([line]), [])
        ok = line.endswith("\n") and len(fields) == len(header) and column is not None
        try:
            steps = int(float(fields[column])) if ok else None
        except ValueError:
            steps = None
        if steps is not None and steps <= until and dropped is None:
            kept.append(line)
        elif steps is not None:
            dropped = max(dropped or steps, steps)
    return header, kept, dropped


class ResumableCSVOutput(KVWriter):
    """progress.csv in SB3's CSV format, resumable and safe to kill: it appends to the rows kept
    at the checkpoint (`keep_until` steps) and, when new columns appear, rewrites the file
    atomically. (A writer of its own, not a CSVOutputFormat: that one truncates the file when
    it opens it and rewrites it in place when columns appear.)"""

    separator, quotechar = ",", '"'

    def __init__(self, path: Path, keep_until: int | None):
        self.path = Path(path)
        self.keys: list[str] = []
        self.dropped_until = None  # the most steps of a row dropped on resume, if any
        rows = []
        if keep_until is not None and self.path.is_file():
            self.keys, rows, self.dropped_until = kept_rows(self.path, keep_until)
        self._rewrite(rows)
        self.file = open(self.path, "a+")

    def _rewrite(self, rows: list[str]) -> None:
        header = ",".join(self.keys) + "\n" if self.keys else ""
        atomic_write_text(self.path, header + "".join(rows))

    def write(self, key_values, key_excluded, step: int = 0) -> None:
        key_values = filter_excluded_keys(key_values, key_excluded, "csv")
        extra = [k for k in key_values if k not in self.keys]
        if extra:
            self.file.close()
            old = self.path.read_text().splitlines(keepends=True)[1:]
            rows = [line[:-1] + self.separator * len(extra) + "\n" for line in old]
            self.keys.extend(extra)
            self._rewrite(rows)
            self.file = open(self.path, "a+")
        # The row as CSVOutputFormat writes it.
        for i, key in enumerate(self.keys):
            if i > 0:
                self.file.write(self.separator)
            value = key_values.get(key)
            for kind, name in _UNSUPPORTED:
                if isinstance(value, kind):
                    raise FormatUnsupportedError(["csv"], name)
            if isinstance(value, str):
                quoted = value.replace(self.quotechar, self.quotechar + self.quotechar)
                self.file.write(self.quotechar + quoted + self.quotechar)
            elif value is not None:
                self.file.write(str(value))
        self.file.write("\n")
        self.file.flush()

    def close(self) -> None:
        self.file.close()


class PurgingTensorBoardOutput(TensorBoardOutputFormat):
    """SB3's TensorBoard output; on a resume its writer purges the events after the checkpoint
    (`SummaryWriter(purge_step=...)`: TensorBoard hides the killed session's later events).
    SB3's constructor is not run: it would open a second events file that cannot purge."""

    def __init__(self, folder: str, purge_step: int | None):
        adopt_summary_writer(self, SummaryWriter(log_dir=folder, purge_step=purge_step))


class RunLogger(Logger):
    """SB3's logger, with the counters it restarts per session continued: `time/iterations`
    and `time/time_elapsed` are offset by their values at the checkpoint (`offsets`)."""

    def __init__(self, folder: str, output_formats, offsets: dict):
        super().__init__(folder, output_formats)
        self.offsets = offsets

    def record(self, key: str, value, exclude=None) -> None:
        if key in self.offsets:
            value = value + self.offsets[key]
        super().record(key, value, exclude)


def open_run_logger(
    folder: Path, resume_from: int | None, iterations: int = 0, wall_time_s: float = 0.0
) -> tuple[RunLogger, ResumableCSVOutput]:
    """The logger of a run's session writing into `folder`, and its CSV output (which knows
    what a resume dropped); `resume_from` is the checkpoint's step count (None for a new run),
    `iterations` and `wall_time_s` the counters there."""
    folder.mkdir(parents=True, exist_ok=True)
    csv_out = ResumableCSVOutput(folder / "progress.csv", keep_until=resume_from)
    purge_step = None if resume_from is None else resume_from + 1
    logger = RunLogger(
        str(folder),
        [csv_out, PurgingTensorBoardOutput(str(folder), purge_step=purge_step)],
        offsets={"time/iterations": int(iterations), "time/time_elapsed": int(wall_time_s)},
    )
    return logger, csv_out
