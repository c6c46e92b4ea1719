"""Every sensor type the description format accepts is simulated and published."""

from robotrial.model.robot import SENSOR_TYPES
from robotrial.ros.sim_node import SENSOR_TOPICS
from robotrial.sim.sensor_kinds import SENSOR_KINDS


def test_every_sensor_type_has_a_builder_and_topics():
    assert set(SENSOR_KINDS) == set(SENSOR_TYPES)
    assert set(SENSOR_TOPICS) == set(SENSOR_TYPES)
    for kind in SENSOR_TYPES:
        topics = SENSOR_TOPICS[kind]("s", True)
        assert "s" in topics, f"{kind}: the sensor's own stream has no topic"
