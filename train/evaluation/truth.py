"""The trackers' ground truth, one frame at a time: labelled boxes with identities that restart at a placement.

Where the engine placed a humanoid for a restart (its box's discontinuity flag), the ground truth starts a
new identity: no tracker can follow a jump of metres, and none is charged an identity switch or credited a
match across it (docs/usage.md, "Restarts").
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from train.tracking.types import GroundTruthFrame


class TruthIds:
    """Identities of one clip's labelled tracks, frame after frame in order: (track id, segment) -> id."""

    def __init__(self) -> None:
        self.identity: dict[tuple[int, int], int] = {}
        self.segment: dict[int, int] = {}

    def frame(self, boxes: NDArray[np.floating], track_id: NDArray[np.integer], placed: NDArray[np.bool_]
              ) -> GroundTruthFrame:
        """The next frame's ground truth from its boxes (G, 7), track ids (G,) and discontinuity flags (G,)."""
        for track, jumped in zip(track_id.tolist(), placed.tolist()):
            self.segment[track] = self.segment.get(track, 0) + int(jumped)
        ids = [self.identity.setdefault((track, self.segment[track]), len(self.identity))
               for track in track_id.tolist()]
        return GroundTruthFrame(boxes, np.array(ids, np.int64))

    def state(self) -> dict[str, NDArray[np.int64]]:
        """The identities given so far, as plain arrays (a resumed run's `restore`)."""
        return {"truth_identity": np.array([(t, s, i) for (t, s), i in self.identity.items()], np.int64).reshape(-1, 3),
                "truth_segment": np.array(list(self.segment.items()), np.int64).reshape(-1, 2)}

    def restore(self, state: dict[str, NDArray[np.int64]]) -> None:
        self.identity = {(t, s): i for t, s, i in state["truth_identity"].tolist()}
        self.segment = dict(map(tuple, state["truth_segment"].tolist()))
