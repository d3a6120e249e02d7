# Copyright 2026 jacket_cloth_ros maintainers. Licensed under the Apache License, Version 2.0.
"""The package as colcon installs it, and `ros2 run` resolution as ros2cli does it."""

import ast
import os
import subprocess
import sys
from glob import glob

import pytest

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


@pytest.fixture(scope='module')
def installed(tmp_path_factory):
    """`setup.py install` the way colcon's ament_python build calls it, into a fresh prefix."""
    prefix = tmp_path_factory.mktemp('install')
    build = tmp_path_factory.mktemp('build')
    subprocess.run(
        [sys.executable, 'setup.py', '-q', 'build', '--build-base', str(build), 'install',
         '--prefix', str(prefix), '--record', str(build / 'files.txt'),
         '--single-version-externally-managed'],
        cwd=ROOT, check=True, capture_output=True)
    return prefix


def _executables(prefix, package):
    """ros2cli's ros2pkg.api.get_executable_paths: files in <prefix>/lib/<package>."""
    folder = os.path.join(prefix, 'lib', package)
    return sorted(f for f in os.listdir(folder)
                  if os.access(os.path.join(folder, f), os.X_OK)
                  and os.path.isfile(os.path.join(folder, f)))


def test_ros2_run_finds_the_node_through_the_ament_index(installed):
    from ament_index_python.packages import get_package_prefix, get_package_share_directory
    env_before = os.environ.get('AMENT_PREFIX_PATH')
    os.environ['AMENT_PREFIX_PATH'] = str(installed)
    try:
        prefix = get_package_prefix('jacket_cloth_ros')
        share = get_package_share_directory('jacket_cloth_ros')
    finally:
        if env_before is None:
            del os.environ['AMENT_PREFIX_PATH']
        else:
            os.environ['AMENT_PREFIX_PATH'] = env_before
    assert prefix == str(installed)
    assert _executables(prefix, 'jacket_cloth_ros') == ['jacket_cloth', 'jacket_cloth_crowd',
                                                        'jacket_cloth_node']
    for name in ('package.xml', 'config/character.urdf', 'config/jacket_rig.yaml',
                 'config/fabrics.yaml', 'config/node_params.yaml', 'config/crowd.yaml',
                 'launch/jacket_cloth.launch.py', 'launch/jacket_cloth_crowd.launch.py'):
        assert os.path.isfile(os.path.join(share, name)), name
    # The installed script runs the installed code (what `ros2 run ... --help` would do).
    site = glob(os.path.join(str(installed), 'lib', 'python3*', 'site-packages'))[0]
    env = dict(os.environ, PYTHONPATH=site, AMENT_PREFIX_PATH=str(installed))
    out = subprocess.run([os.path.join(prefix, 'lib', 'jacket_cloth_ros', 'jacket_cloth_node'),
                          '--help'], env=env, capture_output=True, text=True, timeout=60)
    assert out.returncode == 0 and 'joint_states' in out.stdout
    out = subprocess.run([os.path.join(prefix, 'lib', 'jacket_cloth_ros', 'jacket_cloth_crowd'),
                          '--help'], env=env, capture_output=True, text=True, timeout=60)
    assert out.returncode == 0 and 'characters:=' in out.stdout


def _prefix_files(prefix, package):
    """The package's files in an ament prefix, as paths relative to it (links followed)."""
    found = set()
    index = os.path.join('share', 'ament_index', 'resource_index', 'packages', package)
    if os.path.isfile(os.path.join(prefix, index)):
        found.add(index)
    for top in (os.path.join('share', package), os.path.join('lib', package)):
        for folder, _, files in os.walk(os.path.join(prefix, top)):
            found.update(os.path.relpath(os.path.join(folder, f), prefix) for f in files
                         if os.path.isfile(os.path.join(folder, f)))
    return found


def test_the_ament_prefix_in_use_holds_what_colcon_installs(installed):
    # make's .venv (links to the checkout) or a colcon install, as AMENT_PREFIX_PATH finds the
    # package: what ros2 run and ros2 launch read there is what setup.py installs.
    from ament_index_python.packages import get_package_prefix
    in_use = get_package_prefix('jacket_cloth_ros')
    assert _prefix_files(in_use, 'jacket_cloth_ros') == _prefix_files(installed,
                                                                      'jacket_cloth_ros')
    lib = os.path.join(in_use, 'lib', 'jacket_cloth_ros')
    assert _executables(in_use, 'jacket_cloth_ros') == _executables(installed, 'jacket_cloth_ros')
    assert all(os.access(os.path.join(lib, f), os.X_OK) for f in os.listdir(lib))


def test_package_xml_is_format_3_ament_python():
    from catkin_pkg.package import parse_package
    pkg = parse_package(ROOT)
    assert pkg.package_format == 3 and pkg.name == 'jacket_cloth_ros'
    assert pkg.get_build_type() == 'ament_python'
    deps = {d.name for d in pkg.exec_depends}
    assert {'rclpy', 'sensor_msgs', 'tf2_msgs', 'visualization_msgs', 'diagnostic_msgs',
            'urdfdom_py'} <= deps


def test_launch_file_is_valid_python_with_a_launch_description():
    with open(os.path.join(ROOT, 'launch_scripts', 'jacket_cloth.launch.py')) as f:
        tree = ast.parse(f.read())
    assert 'generate_launch_description' in {n.name for n in tree.body
                                             if isinstance(n, ast.FunctionDef)}


def _imported_modules(tree):
    """Absolute module names a module imports, and one-word strings, which may name a module
    to import_module or ``python -m`` (prose mentioning one is not a leak)."""
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            yield from (alias.name for alias in node.names)
        elif isinstance(node, ast.ImportFrom) and node.level == 0:
            yield node.module
        elif isinstance(node, ast.Constant) and isinstance(node.value, str):
            yield node.value.strip()


def test_the_product_never_imports_the_lab():
    # The lab depends on the product, never the other way, so an install can leave it out.
    leaks = []
    for path in glob(os.path.join(ROOT, 'jacket_cloth_ros', '**', '*.py'), recursive=True):
        with open(path, encoding='utf-8') as f:
            tree = ast.parse(f.read(), path)
        leaks += [f'{os.path.relpath(path, ROOT)}: {name}' for name in _imported_modules(tree)
                  if name.split('.')[0] == 'jacket_cloth_lab']
    assert not leaks, leaks


def test_an_install_leaves_the_lab_out(installed):
    site = glob(os.path.join(str(installed), 'lib', 'python3*', 'site-packages'))[0]
    assert os.path.isdir(os.path.join(site, 'jacket_cloth_ros', 'motion'))
    assert not os.path.exists(os.path.join(site, 'jacket_cloth_lab'))


def test_the_environment_has_the_node_and_the_tools_as_commands():
    # make installs the package (editable) into .venv, so a machine without ROS starts the
    # node as `.venv/bin/jacket_cloth_node` instead of guessing a module path.
    bin_dir = os.path.dirname(sys.executable)
    for command in ('jacket_cloth_node', 'jacket_cloth'):
        assert os.access(os.path.join(bin_dir, command), os.X_OK), command
    done = subprocess.run([os.path.join(bin_dir, 'jacket_cloth'), '--help'],
                          capture_output=True, text=True, timeout=60)
    assert done.returncode == 0 and 'replay' in done.stdout


def test_the_node_runs_without_mcap_and_recording_says_what_it_needs():
    # mcap comes through a pip rosdep key, which a packaged install may leave out: the node
    # must start without it; only recording needs it, and says how to get it.
    script = '''
import sys
class NoMcap:
    def find_spec(self, name, path=None, target=None):
        if name == 'mcap' or name.startswith('mcap.'):
            raise ImportError('no mcap here')
sys.meta_path.insert(0, NoMcap())
import jacket_cloth_ros.ros.node
from jacket_cloth_ros.recording.writer import SessionRecorder
try:
    SessionRecorder(sys.argv[1])
except OSError as e:
    print(e)
'''
    import tempfile
    with tempfile.TemporaryDirectory() as folder:
        done = subprocess.run([sys.executable, '-c', script, os.path.join(folder, 'x.mcap')],
                              capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    assert 'recording needs the mcap package (rosdep key mcap-ros2-support)' in done.stdout
