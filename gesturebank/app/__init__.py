"""The application floor: a dataset's build (takes, views, clips, workers, progress) and the
commands' work, between the stages and the command line (docs/architecture.md "Floors")."""

# A terminal narrower than this gets the narrow forms: tables without vertical rules, short
# headers with a units line, compact progress lines (80 columns fit). Every listing reads it here.
NARROW_COLUMNS = 100
