"""Costmap layers by Nav2 plugin type: each registered type builds its layer; unknown types say what was meant."""

from __future__ import annotations

import pytest

from navlog.errors import ConfigError
from navlog.replay.nav2.costmap import (
    LAYERS,
    Costmap2D,
    CostmapParams,
    InflationLayer,
    ObstacleLayer,
    StaticLayer,
    default_costmap_params,
)

BUILT = {
    "nav2_costmap_2d::StaticLayer": StaticLayer,
    "nav2_costmap_2d::ObstacleLayer": ObstacleLayer,
    "nav2_costmap_2d::VoxelLayer": ObstacleLayer,
    "nav2_costmap_2d::InflationLayer": InflationLayer,
}


@pytest.mark.parametrize("plugin", [name for name in LAYERS if LAYERS[name] is not None])
def test_each_registered_layer_builds_from_its_parameters(plugin):
    entry = LAYERS[plugin]
    params = entry.params(plugin=plugin)
    cm = Costmap2D(CostmapParams(plugins=("layer",), layers={"layer": params}))
    assert [type(layer) for layer in cm.layers] == [BUILT[plugin]]
    assert cm.layers[0].name == "layer" and cm.layers[0].p is params


def test_humble_slash_names_are_the_same_plugins():
    assert LAYERS["nav2_costmap_2d/InflationLayer"] is LAYERS["nav2_costmap_2d::InflationLayer"]
    assert LAYERS.implementation("nav2_costmap_2d/StaticLayer") is StaticLayer


def test_unknown_layer_names_what_was_meant():
    with pytest.raises(
        ConfigError,
        match=r"unknown costmap layer plugin 'nav2_costmap_2d::ObstcaleLayer' \(did you mean 'nav2_costmap_2d::ObstacleLayer'\?\)",
    ):
        LAYERS.implementation("nav2_costmap_2d::ObstcaleLayer")
    with pytest.raises(ConfigError, match="unknown costmap layer plugin"):
        Costmap2D(
            CostmapParams(plugins=("x",), layers={"x": LAYERS["nav2_costmap_2d::StaticLayer"].params(plugin="x")})
        )


def test_known_but_not_implemented_layer():
    assert "nav2_costmap_2d::KeepoutFilter" in LAYERS and LAYERS["nav2_costmap_2d::KeepoutFilter"] is None
    with pytest.raises(ConfigError, match="read, not implemented by navlog"):
        LAYERS.implementation("nav2_costmap_2d::KeepoutFilter")


def test_default_costmap_is_nav2s_three_layers():
    cm = Costmap2D(default_costmap_params())
    assert [(layer.name, type(layer)) for layer in cm.layers] == [
        ("static_layer", StaticLayer),
        ("obstacle_layer", ObstacleLayer),
        ("inflation_layer", InflationLayer),
    ]
    assert [layer.name for layer in cm.static_layers] == ["static_layer"]
    assert [layer.name for layer in cm.obstacle_layers] == ["obstacle_layer"]
