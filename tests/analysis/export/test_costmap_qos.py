"""Nav2's costmaps keep their transient-local QoS in a recording and in an exported bag, as Nav2 publishes
them (RViz's Nav2 view subscribes transient-local and shows nothing offered volatile)."""

from __future__ import annotations

import yaml

from navlog.replay import messages as m
from tests.analysis import sample_nav_log as sample
from tests.analysis.export.bags import export_bag, rosbags_messages


def channel_durability(log) -> dict[str, int]:
    from mcap.reader import make_reader

    with open(log, "rb") as f:
        channels = make_reader(f).get_summary().channels.values()
    return {c.topic: yaml.safe_load(c.metadata["offered_qos_profiles"])[0]["durability"] for c in channels}


def test_latched_topics_are_tf_static_map_and_nav2_costmaps():
    for topic in ("/tf_static", "/map", "/global_costmap/costmap", "/local_costmap/costmap_raw"):
        assert m.is_latched(topic), topic
    assert m.is_latched("/robot1/local_costmap/costmap_updates")
    for topic in ("/scan", "/global_costmap/published_footprint", "/plan", "/costmap_filter_info", "/tf"):
        assert not m.is_latched(topic), topic


def test_costmaps_are_recorded_transient_local(tmp_path):
    log = sample.write_sample_log(tmp_path / "c.mcap", costmap_hz=1.0, with_events=False)
    durability = channel_durability(log)
    # rosbag2's durability numbers: 1 transient local, 2 volatile
    assert durability["/global_costmap/costmap"] == 1
    assert durability["/map"] == 1 and durability["/tf_static"] == 1
    assert durability["/scan"] == 2 and durability["/odom"] == 2


def test_costmaps_recorded_volatile_are_exported_transient_local(tmp_path, monkeypatch):
    from rosbags.interfaces import QosDurability, QosReliability

    with monkeypatch.context() as patch:  # a log written before: costmaps offered volatile
        patch.setattr(
            m, "qos_for", lambda topic: m.QOS_TRANSIENT_LOCAL if topic in m.LATCHED_TOPICS else m.QOS_VOLATILE
        )
        log = sample.write_sample_log(tmp_path / "old.mcap", costmap_hz=1.0, with_events=False)
    assert channel_durability(log)["/global_costmap/costmap"] == 2
    for distro in ("humble", "jazzy"):
        out = tmp_path / f"bag-{distro}"
        assert export_bag(log, out, "--distro", distro) == 0
        _, qos = rosbags_messages(out)
        (q,) = qos["/global_costmap/costmap"]
        assert (q.durability, q.reliability, q.depth) == (QosDurability.TRANSIENT_LOCAL, QosReliability.RELIABLE, 1)
        assert qos["/scan"][0].durability == QosDurability.VOLATILE
