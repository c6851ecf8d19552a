"""Install eye_bci_ros2 as an ament_python package."""

from glob import glob
import os

from setuptools import find_packages, setup

package_name = 'eye_bci_ros2'

# Executables, as `ros2 run eye_bci_ros2 <exe>` finds them in lib/eye_bci_ros2.
console_scripts = [
    'lsl_gaze_bridge = eye_bci_ros2.nodes.lsl_gaze_bridge:main',
    'camera_tracker = eye_bci_ros2.nodes.camera_tracker:main',
    'marker_projector = eye_bci_ros2.nodes.marker_projector:main',
    'choice_arbiter = eye_bci_ros2.nodes.choice_arbiter:main',
    'choice_menu = eye_bci_ros2.nodes.choice_menu:main',
    'gaze_validation = eye_bci_ros2.nodes.gaze_validation:main',
    'eye_bci = eye_bci_ros2.nodes.eye_bci:main',
    'sim_rviz_view = eye_bci_ros2.sim.rviz_view:main',
    'sim_gaze = eye_bci_ros2.sim.gaze_outlet:main',
    'calibrate = eye_bci_ros2.tools.calibrate:main',
    'accuracy_test = eye_bci_ros2.experiments.accuracy_test:main',
    'demo = eye_bci_ros2.experiments.demo:main',
    'find_panel = eye_bci_ros2.tools.find_panel:main',
    'monitor = eye_bci_ros2.tools.monitor:main',
    'view_animated_bridge = eye_bci_ros2.nodes.view_animated_bridge:main',
    'ssvep_decoder = eye_bci_ros2.nodes.ssvep_decoder:main',
    'sim_eeg = eye_bci_ros2.sim.eeg_outlet:main',
    'ssvep_calibrate = eye_bci_ros2.tools.ssvep_calibrate:main',
    'ssvep_stimulus = eye_bci_ros2.nodes.ssvep_stimulus:main',
    'ssvep_stimulus_map = eye_bci_ros2.nodes.ssvep_stimulus_map:main',
]

setup(
    name=package_name,
    version='0.1.0',
    packages=find_packages(exclude=['test', 'bench']),
    data_files=[
        ('share/ament_index/resource_index/packages', ['resource/' + package_name]),
        ('share/' + package_name, ['package.xml']),
        (os.path.join('share', package_name, 'config'),
         glob('config/*.yaml') + glob('config/*.rviz')),
        (os.path.join('share', package_name, 'launch'), glob('launch/*.launch.py')),
    ],
    install_requires=['setuptools'],
    zip_safe=True,
    maintainer='eye_bci_ros2 developers',
    maintainer_email='eye-bci-ros2@example.org',
    description='Gaze-driven choice among RViz markers over LSL, for BCI assistive robots.',
    license='BSD-3-Clause',
    tests_require=['pytest'],
    entry_points={'console_scripts': console_scripts},
)
