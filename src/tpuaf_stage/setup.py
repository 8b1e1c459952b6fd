from catkin_pkg.python_setup import generate_distutils_setup
from setuptools import setup

# tpuaf_stage: ROS-free simulator logic (world files, presets, stepping loop).
setup(**generate_distutils_setup(packages=["tpuaf_stage"], package_dir={"": "src"}))
