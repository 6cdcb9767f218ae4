"""The static layer: a map's values as costs, unknown tracked or not, trinary or scaled."""

from __future__ import annotations

import numpy as np

from navlog.replay.nav2.costmap import Costmap2D, StaticLayerParams
from tests.replay.nav2.costmap.grids import costmap_params, static_map


def test_static_layer_interpretation_and_unknown():
    data = np.array([[-1, 0, 50, 100]], dtype=np.int8)
    for track, trinary, expected in (
        (False, True, [0, 0, 0, 254]),
        (True, True, [255, 0, 0, 254]),
        (True, False, [255, 0, 127, 254]),
    ):
        cm = Costmap2D(
            costmap_params(
                track_unknown_space=track, trinary_costmap=trinary, layers={"static_layer": StaticLayerParams()}
            )
        )
        cm.set_static_map(static_map(data, 0.1))
        cm.update(0.0, 0.0)
        assert cm.costs[0].tolist() == expected
        assert (cm.size_x, cm.size_y, cm.resolution) == (4, 1, 0.1)
