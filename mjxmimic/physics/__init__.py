"""Physics backends behind one seam (`mjxmimic.physics.backend.Physics`): MJX impl='warp' and
impl='jax' (`mjxmimic.physics.mjx`), MuJoCo C with numpy (`mjxmimic.physics.cpu`); the PD law
(`mjxmimic.physics.pd`) that all three apply each substep."""
