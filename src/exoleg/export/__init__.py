"""Model export: URDF and MJCF writers for a leg, lumped or with welded parts."""

from exoleg.export.writers import Mode, to_mjcf, to_urdf, write_mjcf, write_urdf

__all__ = ["Mode", "to_mjcf", "to_urdf", "write_mjcf", "write_urdf"]
