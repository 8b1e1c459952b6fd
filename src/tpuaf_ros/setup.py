from catkin_pkg.python_setup import generate_distutils_setup
from setuptools import find_packages, setup

# Every subpackage of tpuaf, and the built-in maps shipped inside it (found via tpuaf.paths).
setup(
    **generate_distutils_setup(
        packages=find_packages("src"),
        package_dir={"": "src"},
        package_data={"tpuaf": ["data/maps/*/*"]},
    )
)
