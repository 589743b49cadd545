"""The application floor: a dataset's build (takes, views, clips, workers, progress) and the
commands' work, between the stages and the command line (docs/architecture.md "Floors")."""
