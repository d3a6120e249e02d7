from glob import glob

from setuptools import find_packages, setup

package_name = 'jacket_cloth_ros'

setup(
    name=package_name,
    version='0.1.0',
    # Only the product is installed: the lab (jacket_cloth_lab) runs from a source checkout
    # (make bench) and nothing in jacket_cloth_ros imports it.
    packages=find_packages(include=[package_name, package_name + '.*']),
    data_files=[
        ('share/ament_index/resource_index/packages', ['resource/' + package_name]),
        ('share/' + package_name, ['package.xml']),
        ('share/' + package_name + '/config', glob('config/*.*')),
        ('share/' + package_name + '/config/examples', glob('config/examples/*')),
        ('share/' + package_name + '/config/view', glob('config/view/*')),
        ('share/' + package_name + '/launch', glob('launch_scripts/*.launch.py')),
    ],
    install_requires=['setuptools'],
    zip_safe=True,
    maintainer='jacket_cloth_ros maintainers',
    maintainer_email='jacket_cloth_ros@example.com',
    description='Jacket and hood secondary motion (Alan Wake cloth method) for ROS 2.',
    license='Apache-2.0',
    extras_require={'test': ['pytest']},
    entry_points={
        'console_scripts': [
            # Through signals: a Ctrl-C while Python imports is one line, not a traceback.
            'jacket_cloth_node = jacket_cloth_ros.signals:node',
            'jacket_cloth = jacket_cloth_ros.signals:tools',
            'jacket_cloth_crowd = jacket_cloth_ros.signals:crowd',
        ],
    },
)
