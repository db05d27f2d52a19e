"""What a batch returns: one :class:`BatchResult` per scene, the :class:`BatchSummary` of a
run and the :class:`BatchInterrupted` exception that carries it when a signal stops the batch."""

from __future__ import annotations

from dataclasses import asdict, dataclass, field


@dataclass
class BatchResult:
    """Outcome of one scene: ``status`` is ``done``, ``skipped`` (already complete and up to
    date), ``failed`` or ``unfinished`` (the batch was interrupted before it finished).

    Parameters
    ----------
    name : str
        Scene name (the output's file stem).
    path : str
        Output EXR path.
    status : {"done", "skipped", "failed", "unfinished"}
        Outcome.
    seconds : float
        Wall time spent on the scene [s].
    error : str
        One-line error message of a failed scene (empty otherwise).
    """

    name: str
    path: str
    status: str
    seconds: float = 0.0
    error: str = ""


@dataclass
class BatchSummary:
    """All results of a batch, with counts and a readable report.

    Parameters
    ----------
    results : list of BatchResult
        One entry per scene, in batch order.
    seconds : float
        Wall time of the whole batch [s].
    interrupted : str
        ``""``, or the signal that stopped the batch (``"SIGINT"``, ``"SIGTERM"``).
    """

    results: list = field(default_factory=list)
    seconds: float = 0.0
    #: ``""``, or the signal that stopped the batch (``"SIGINT"``, ``"SIGTERM"``)
    interrupted: str = ""

    def count(self, status: str) -> int:
        return sum(r.status == status for r in self.results)

    @property
    def failed(self) -> list:
        return [r for r in self.results if r.status == "failed"]

    @property
    def ok(self) -> bool:
        return not self.failed

    def text(self) -> str:
        lines = [
            f"{len(self.results)} scenes: {self.count('done')} rendered, "
            f"{self.count('skipped')} already complete (skipped), {self.count('failed')} failed "
            f"in {self.seconds:.1f} s"
        ]
        if self.interrupted:
            lines.append(f"interrupted by {self.interrupted}: {self.count('unfinished')} scenes "
                         "not finished (no partial files); run the same command again to resume")
        for r in self.failed:
            lines.append(f"  FAILED {r.name}: {r.error}")
        return "\n".join(lines)

    def to_dict(self) -> dict:
        return {"seconds": self.seconds, "done": self.count("done"),
                "skipped": self.count("skipped"), "failed": self.count("failed"),
                "unfinished": self.count("unfinished"), "interrupted": self.interrupted,
                "results": [asdict(r) for r in self.results]}


class BatchInterrupted(KeyboardInterrupt):
    """Raised by :func:`run_batch` when SIGINT (Ctrl-C) or SIGTERM stopped it.

    The workers have been stopped and no partial file is left; :attr:`summary` says what
    finished (also written to ``batch_summary.json``) and :attr:`signal_name` what stopped it.
    """

    def __init__(self, summary: BatchSummary, signal_name: str):
        super().__init__(f"batch interrupted by {signal_name}")
        self.summary = summary
        self.signal_name = signal_name

