# Nav2 with mapkeeper node in place of nav2_map_server's map_server: an example.
#
#   ros2 launch mapkeeper_nav2.launch.py mapkeeper_params:=/path/node.yaml \
#       nav2_params:=/path/nav2_params.yaml use_sim_time:=false
#
# mapkeeper node is not a ROS package: it is the `mapkeeper` binary (pure Rust, on PATH or
# given by `mapkeeper_bin`), run as a process. It publishes /map as map_server does (reliable,
# transient local), so AMCL and the costmaps take it unchanged, and then keeps it up to date
# (/map_updates, and the readiness barrier of docs/ros2/nav2_params_static_layer.yaml).
#
# Laid out as nav2_bringup is on its jazzy branch: launch/navigation_launch.py (planner,
# controller, BT navigator, ...; arguments use_sim_time, params_file, autostart, ...) is
# included as it is. launch/localization_launch.py is NOT included: it starts map_server
# and amcl under one lifecycle manager (node_names [map_server, amcl]), and map_server would
# publish a second, stale /map. AMCL is started here the way that file starts it, alone.
# AMCL takes every new /map (its first_map_only defaults to false), so it localises on the
# updated map.

from launch import LaunchDescription
from launch.actions import DeclareLaunchArgument, ExecuteProcess, IncludeLaunchDescription
from launch.launch_description_sources import PythonLaunchDescriptionSource
from launch.substitutions import LaunchConfiguration, PathJoinSubstitution
from launch_ros.actions import Node
from launch_ros.substitutions import FindPackageShare


def generate_launch_description():
    mapkeeper_bin = LaunchConfiguration('mapkeeper_bin')
    mapkeeper_params = LaunchConfiguration('mapkeeper_params')
    nav2_params = LaunchConfiguration('nav2_params')
    use_sim_time = LaunchConfiguration('use_sim_time')
    bringup = FindPackageShare('nav2_bringup')

    return LaunchDescription([
        DeclareLaunchArgument('mapkeeper_bin', default_value='mapkeeper',
                              description='The mapkeeper binary'),
        DeclareLaunchArgument('mapkeeper_params',
                              description="mapkeeper node's parameter file (docs/ros2/node.yaml)"),
        DeclareLaunchArgument('nav2_params',
                              default_value=PathJoinSubstitution(
                                  [bringup, 'params', 'nav2_params.yaml']),
                              description='Nav2 parameters, with the static layer of '
                                          'docs/ros2/nav2_params_static_layer.yaml merged in'),
        DeclareLaunchArgument('use_sim_time', default_value='false',
                              description='Use /clock (simulation, bag replay)'),

        # The map: `mapkeeper node --params FILE` instead of map_server. It has no lifecycle
        # (it publishes /map at once) and no command-line parameter overrides: it reads
        # use_sim_time from its own file, so set the same value there as here. On shutdown
        # launch sends SIGINT, on which the node saves the map (with save_dir set): give it
        # time before SIGTERM.
        ExecuteProcess(
            cmd=[mapkeeper_bin, 'node', '--params', mapkeeper_params],
            name='mapkeeper',
            output='screen',
            sigterm_timeout='15',
        ),

        # Localisation: AMCL alone, with its own lifecycle manager (no map_server to manage).
        Node(
            package='nav2_amcl',
            executable='amcl',
            name='amcl',
            output='screen',
            parameters=[nav2_params, {'use_sim_time': use_sim_time}],
        ),
        Node(
            package='nav2_lifecycle_manager',
            executable='lifecycle_manager',
            name='lifecycle_manager_localization',
            output='screen',
            parameters=[{'use_sim_time': use_sim_time,
                         'autostart': True,
                         'node_names': ['amcl']}],
        ),

        # Navigation, as nav2_bringup ships it.
        IncludeLaunchDescription(
            PythonLaunchDescriptionSource(
                PathJoinSubstitution([bringup, 'launch', 'navigation_launch.py'])),
            launch_arguments={
                'use_sim_time': use_sim_time,
                'params_file': nav2_params,
                'autostart': 'true',
            }.items(),
        ),
    ])
