"""Articulated upper-body model and its projection (Menezes et al. sec. 6, Schmidt et al. sec. 4)."""
