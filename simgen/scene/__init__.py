"""The scene: the analytic pitch with its painted lines (`pitch`) and the static meshes around it (`static`)."""
