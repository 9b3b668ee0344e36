"""The scenes shipped with warpfree (installed as ``warpfree.scenes``): one module per scene, each with
``build(**params)``, a docstring whose first line says what it does, and ``SMALLEST``, its smallest run.
``warpfree list`` lists them, ``warpfree run NAME`` runs one (:mod:`warpfree.scene_loader`)."""
