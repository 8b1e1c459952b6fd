from catkin_pkg.python_setup import generate_distutils_setup
from setuptools import find_packages, setup

# Every subpackage of tpuaf. The built-in maps (top-level maps/, linked as src/tpuaf/data/maps)
# are installed as its package data by CMakeLists.txt (found via tpuaf.paths).
setup(
    **generate_distutils_setup(
        packages=find_packages("src"),
        package_dir={"": "src"},
    )
)
