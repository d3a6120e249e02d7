# Copyright 2026 jacket_cloth_ros maintainers. Licensed under the Apache License, Version 2.0.
"""The simulation core: skeleton, rig, cloth, hood and the fixed-step driver. No ROS here.

Layers, each importing only those below it (test/test_core_layers.py holds them to it):

1. types and compiling: ``bundles`` (the named arrays the compiled steps take), ``compiled``
   (``njit``, the cache stamp, FixedTypes), ``choices``, ``config``, ``transforms``,
   ``geometry``;
2. the compiled physics, ``physics/``: pose, colliders, cloth, hood, step, crowd, sampling,
   skinning;
3. building a character's model: ``skeleton``, ``bone_layer``, ``urdf_colliders``, ``rig``
   (``model_of``), ``fabric``, ``params``, ``jacket_mesh`` and ``body_mesh`` (what a person
   sees);
4. drivers: ``inputs``, ``lod``, ``measures``, ``body_proxy`` (the body the measures see),
   ``stepping`` (a character's compiled call, alone or in a crowd), ``simulation``
   (JacketSimulation), ``crowd``.
"""
