"""Install eye_bci_ros2 as an ament_python package."""

from glob import glob
import os
import runpy

from setuptools import find_packages, setup

package_name = 'eye_bci_ros2'

# Executables, as `ros2 run eye_bci_ros2 <exe>` finds them in lib/eye_bci_ros2: from the one
# registry (read by path: the package and rclpy cannot be imported while it is being built).
_REGISTRY = runpy.run_path(os.path.join(os.path.dirname(os.path.abspath(__file__)),
                                        package_name, 'ros', 'registry.py'))
console_scripts = list(_REGISTRY['console_scripts']())

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
