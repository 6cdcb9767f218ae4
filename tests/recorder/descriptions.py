"""Small description files for the recorder's tests and the fuzz campaign's seeds: a two-wheeled URDF robot with
either spelling of the diff drive plugin, a Gazebo world with nested models, a frame and an include of a crate
model, and a world of polyline walls."""

from __future__ import annotations

# a 0.3 x 0.24 m base on two wheels (radius 0.05 m, 0.28 m apart) and a rear caster, a 2D laser; root
# base_link; the plugin names its odometry topic and both frames
ROBOT = """<?xml version="1.0"?>
<robot name="wheely">
  <link name="base_link">
    <inertial><mass value="4.0"/><inertia ixx="0.03" iyy="0.04" izz="0.05" ixy="0" ixz="0" iyz="0"/></inertial>
    <collision><origin xyz="0 0 0.07"/><geometry><box size="0.3 0.24 0.08"/></geometry></collision>
  </link>
  <link name="wheel_left">
    <inertial><mass value="0.3"/><inertia ixx="0.0002" iyy="0.0002" izz="0.0004" ixy="0" ixz="0" iyz="0"/></inertial>
    <collision><origin rpy="1.5708 0 0"/><geometry><cylinder radius="0.05" length="0.03"/></geometry></collision>
  </link>
  <joint name="wheel_left_joint" type="continuous">
    <parent link="base_link"/><child link="wheel_left"/><origin xyz="0 0.14 0.05"/><axis xyz="0 1 0"/>
  </joint>
  <link name="wheel_right">
    <inertial><mass value="0.3"/><inertia ixx="0.0002" iyy="0.0002" izz="0.0004" ixy="0" ixz="0" iyz="0"/></inertial>
    <collision><origin rpy="1.5708 0 0"/><geometry><cylinder radius="0.05" length="0.03"/></geometry></collision>
  </link>
  <joint name="wheel_right_joint" type="continuous">
    <parent link="base_link"/><child link="wheel_right"/><origin xyz="0 -0.14 0.05"/><axis xyz="0 1 0"/>
  </joint>
  <link name="caster">
    <inertial><mass value="0.05"/><inertia ixx="0.00001" iyy="0.00001" izz="0.00001" ixy="0" ixz="0" iyz="0"/></inertial>
    <collision><geometry><sphere radius="0.025"/></geometry></collision>
  </link>
  <joint name="caster_joint" type="fixed">
    <parent link="base_link"/><child link="caster"/><origin xyz="-0.12 0 0.025"/>
  </joint>
  <link name="laser"/>
  <joint name="laser_joint" type="fixed">
    <parent link="base_link"/><child link="laser"/><origin xyz="0 0 0.15"/>
  </joint>
  <gazebo reference="laser">
    <sensor name="lidar" type="gpu_lidar">
      <update_rate>10</update_rate><topic>scan</topic><gz_frame_id>laser</gz_frame_id>
      <lidar><scan><horizontal><samples>360</samples><min_angle>-3.14159</min_angle>
      <max_angle>3.12414</max_angle></horizontal></scan><range><min>0.1</min><max>8.0</max></range></lidar>
    </sensor>
  </gazebo>
  <gazebo>
    PLUGIN
  </gazebo>
</robot>
"""
GZ_PLUGIN = """<plugin filename="gz-sim-diff-drive-system" name="gz::sim::systems::DiffDrive">
      <left_joint>wheel_left_joint</left_joint><right_joint>wheel_right_joint</right_joint>
      <wheel_separation>0.28</wheel_separation><wheel_radius>0.05</wheel_radius>
      <max_linear_velocity>0.5</max_linear_velocity><max_angular_velocity>1.5</max_angular_velocity>
      <topic>cmd_vel</topic><odom_topic>odometry/wheels</odom_topic>
      <frame_id>wheel_odom</frame_id><child_frame_id>base_footprint</child_frame_id>
      <odom_publish_frequency>25</odom_publish_frequency>
    </plugin>"""
CLASSIC_PLUGIN = """<plugin name="diff_drive" filename="libgazebo_ros_diff_drive.so">
      <left_joint>wheel_left_joint</left_joint><right_joint>wheel_right_joint</right_joint>
      <wheel_separation>0.28</wheel_separation><wheel_diameter>0.1</wheel_diameter>
      <odometry_topic>odometry/wheels</odometry_topic>
      <odometry_frame>wheel_odom</odometry_frame><robot_base_frame>base_footprint</robot_base_frame>
      <update_rate>25</update_rate>
    </plugin>"""

MODEL_SDF = """<?xml version="1.0"?>
<sdf version="1.9">
  <model name="crate">
    <link name="base"><pose>1 0 0 0 0 0</pose>
      <collision name="c"><pose>0 0 0.5 0 0 0</pose><geometry><box><size>1 2 1</size></box></geometry></collision>
      <visual name="v"><geometry><mesh><uri>meshes/gone.dae</uri></mesh></geometry></visual>
    </link>
  </model>
</sdf>
"""

WORLD_SDF = """<?xml version="1.0"?>
<sdf version="1.9">
  <world name="w">
    <light name="sun" type="directional"/>
    <model name="outer">
      <static>true</static>
      <pose>10 0 0 0 0 1.5707963267948966</pose>
      <frame name="corner"><pose>0 2 0 0 0 0</pose></frame>
      <model name="inner"><pose>1 0 0 0 0 0</pose>
        <link name="l"><pose>0 1 0 0 0 0</pose>
          <collision name="post"><pose>0 0 1 0 0 0</pose>
            <geometry><cylinder><radius>0.1</radius><length>2</length></cylinder></geometry></collision>
        </link>
      </model>
      <link name="l2">
        <collision name="rel"><pose relative_to="corner">0 0 0.25 0 0 0</pose>
          <geometry><box><size>0.5 0.5 0.5</size></box></geometry></collision>
        <collision name="ball"><pose>0 0 3 0 0 0</pose><geometry><sphere><radius>0.5</radius></sphere></geometry></collision>
      </link>
      <include><uri>model://crate</uri><name>crate_1</name><pose>0 0 0 0 0 0</pose></include>
    </model>
  </world>
</sdf>
"""

POLYLINE_WORLD = """<?xml version="1.0"?>
<sdf version="1.9"><world name="w">
  <model name="ground"><static>true</static><link name="l"><collision name="c"><geometry>
    <plane><normal>0 0 1</normal><size>20 20</size></plane></geometry></collision></link></model>
  <model name="pen"><static>true</static><pose>2 1 0 0 0 1.5707963</pose><link name="l">
    <collision name="walls"><pose>0 0 0.1 0 0 0</pose><geometry>
      <polyline><point>-1.5 -1</point><point>1.5 -1</point><point>1.5 1</point><point>-1.5 1</point>
        <height>0.8</height></polyline>
      <polyline><point>-1.2 -0.7</point><point>1.2 -0.7</point><point>1.2 0.7</point><point>-1.2 0.7</point>
        <height>0.8</height></polyline>
    </geometry></collision>
    <collision name="ell"><pose>0 3 0 0 0 -1.5707963</pose><geometry>
      <polyline><point>0 0</point><point>1 0</point><point>1 0.4</point><point>0.4 0.4</point>
        <point>0.4 1</point><point>0 1</point><height>0.5</height></polyline>
    </geometry></collision>
  </link></model>
</world></sdf>
"""
