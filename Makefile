# gesturebank — the two commands that do everything on a fresh machine:
#   make demo   set up .venv with what the demo runs, fetch real sample media, build a dataset,
#               write the QC dashboard
#   make test   set up .venv with every extra, fetch test media, run lint + type checks, build
#               the docs site (strict), run the suite (`make setup`: every extra, nothing run)
#
# Run as root on Debian/Ubuntu, `make` also installs the system packages it needs with apt-get
# (espeak-ng, sox: speech test media; libusb-1.0-0: open3d; chromium: dashboard tests;
# libportaudio2: `live --input mic` and replay's audio on this computer).
# As another user it only tells you which ones are missing.

PYTHON     ?= python3.11
VENV       ?= .venv
PY         := $(VENV)/bin/python
PIP        := $(PY) -m pip
EXTRAS     ?= dev,train,robot,multiview,distributed,docs
MEDIA      ?= $(or $(XDG_CACHE_HOME),$(HOME)/.cache)/gesturebank/samples
DEMO_OUT   ?= demo-out
APT_PKGS   := espeak-ng sox libusb-1.0-0 chromium libportaudio2
MEDIAPIPE  := mediapipe==0.10.14
SCENEDETECT := scenedetect==0.7.2
SILERO_VAD := silero-vad==6.2.3

.PHONY: demo test lint typecheck pytest docs setup system-deps samples clean help

help:
	@sed -n '2,9p' Makefile

# -- setup --------------------------------------------------------------------------------------
system-deps:
	@missing=$$(for p in $(APT_PKGS); do dpkg-query -W -f='$${Status}\n' $$p 2>/dev/null | grep -q '^install ok installed' || echo $$p; done); \
	if [ -z "$$missing" ]; then exit 0; fi; \
	if [ "$$(id -u)" = 0 ] && command -v apt-get >/dev/null; then \
	  echo "apt-get install: $$missing"; \
	  apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq $$missing >/dev/null; \
	else echo "note: missing system packages (install them as root): $$missing"; fi

# The venv, then what pip cannot resolve alone: three packages without their declared deps.
define VENV_WITH
	test -x $(PY) || $(PYTHON) -m venv $(VENV)
	$(PIP) install -q --upgrade pip
	$(PIP) install -q -e "$(1)"
	# mediapipe without its declared deps: they would add a second cv2 (the GUI build) and jax.
	# Its real runtime deps are in pyproject's dependencies.
	$(PIP) install -q --no-deps $(MEDIAPIPE)
	# scenedetect without its declared deps: opencv-python (scenedetect-headless: the headless
	# build) would be a second cv2 beside opencv-contrib-python-headless. Its pure-Python deps
	# (click, platformdirs, tqdm) are in pyproject's dependencies.
	$(PIP) install -q --no-deps $(SCENEDETECT)
	# silero-vad (MIT) for its ONNX speech-activity model only, run on onnxruntime: without its
	# declared deps (torch, torchaudio), which the model does not need.
	$(PIP) install -q --no-deps $(SILERO_VAD)
	touch $@
endef

# What `make demo` runs (build-dataset); `make setup` and `make test`: every extra. README's
# "Install by hand" lists the same commands (tests/test_project_files.py compares them).
$(VENV)/.core: pyproject.toml Makefile
	$(call VENV_WITH,.)

$(VENV)/.installed: pyproject.toml Makefile
	$(call VENV_WITH,.[$(EXTRAS)])
	touch $(VENV)/.core

setup: system-deps $(VENV)/.installed

# the demo needs only the package; `make test` has set up everything before (its first goal)
samples: system-deps $(VENV)/.core
	$(VENV)/bin/gesturebank fetch-samples $(MEDIA)

# -- the two commands ---------------------------------------------------------------------------
demo: samples
	$(VENV)/bin/build-dataset $(MEDIA)/talking $(DEMO_OUT) ; rc=$$?; \
	  if [ $$rc -gt 1 ]; then exit $$rc; fi
	@echo
	@echo "Demo finished. Sample media: $(MEDIA)   Dataset: $(DEMO_OUT)/"
	@test -f $(DEMO_OUT)/qc/index.html && echo "QC dashboard: $(DEMO_OUT)/qc/index.html" || true

# typecheck and docs (~45 s of one core on a fresh clone: mypy has no cache there) run beside
# the suite, which keeps about one of the two cores busy on average; a failure still fails `make
# test`, once the suite has finished
test: setup samples lint
	$(MAKE) --no-print-directory -j3 typecheck docs pytest

lint: setup
	$(VENV)/bin/ruff check gesturebank tests benchmarks examples docs/hooks
	$(VENV)/bin/ruff format --check gesturebank tests benchmarks examples docs/hooks

typecheck: setup
	$(VENV)/bin/mypy

# the site in site/ (mkdocs.yml); --strict: a warning (a broken link, a docstring griffe cannot
# read, a page outside the nav) fails the build
docs: setup
	NO_MKDOCS_2_WARNING=1 $(VENV)/bin/mkdocs build --strict --quiet

pytest: setup
	GESTUREBANK_SAMPLES=$(MEDIA) $(VENV)/bin/pytest

clean:
	rm -rf $(VENV) $(DEMO_OUT) site .pytest_cache .mypy_cache .ruff_cache build *.egg-info
