# The two entry points of a fresh machine: `make demo` and `make test`.
PYTHON ?= python3
VENV := .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed

.PHONY: demo test test-slow lint bench clean

$(STAMP): pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip
	$(BIN)/python -m pip install --quiet -e '.[test,mediapipe]'
	# MediaPipe brings opencv-contrib-python beside the core's headless OpenCV: both
	# install the one cv2 module, so the contrib build is laid again whole (with a GUI,
	# for --show).
	$(BIN)/python -m pip install --quiet --force-reinstall --no-deps \
		"opencv-contrib-python==$$($(BIN)/python -c 'import importlib.metadata as m; print(m.version("opencv-contrib-python"))')"
	$(BIN)/python -c "import cv2, mediapipe, numpy; print('cv2', cv2.__version__, 'numpy', numpy.__version__)"
	# numba compiles the package's loops at their first call and keeps them (its cache,
	# beside the sources): a short track compiles them here, so that a user's first
	# track runs at full speed (benchmarks/one_command.py --cold: about 10 s otherwise).
	$(BIN)/handvar track examples/data/tfjs-asl-hand.mp4 --scale 0.5 --frames 10 \
		--out $(VENV)/first-track --no-video > $(VENV)/first-track.log 2>&1 \
		|| (cat $(VENV)/first-track.log; exit 1)
	rm -rf $(VENV)/first-track $(VENV)/first-track.log
	touch $(STAMP)

# The main job on built-in defaults: the predictors on real recorded motion, then a
# reduced run of the paper's experiment (3 trials x 40 frames) and its report, then the
# example video tracked (60 frames) with the detector inside, and its 3D viewer page.
demo: $(STAMP)
	$(BIN)/handvar predict examples/data/htrack-fingerfist.txt --layout htrack --reset-at 4000
	$(BIN)/handvar experiment --quick --out demo/experiment.zarr
	$(BIN)/handvar report demo/experiment.zarr --out demo/report
	$(BIN)/handvar track examples/data/dex-human-hand-video.mp4 --scale 0.5 --out demo/video \
		--no-video
	$(BIN)/handvar view demo/video --out demo/video/view.html
	@echo "3D viewer of the example video's track: demo/video/view.html"

# The tests run on every core, one test file to a process (pytest-xdist): a file's
# module fixtures are built once.
test: $(STAMP)
	$(BIN)/ruff check src tests benchmarks studies
	$(BIN)/python -m pytest -n auto --dist loadfile

lint: $(STAMP)
	$(BIN)/ruff check src tests benchmarks studies examples
	$(BIN)/ruff format --check src tests benchmarks studies examples

test-slow: $(STAMP)
	$(BIN)/python -m pytest -n auto --dist loadfile -m slow

# Every timing benchmark of benchmarks/ (the accuracy studies are in studies/, each run
# on its own: studies/README.md).
bench: $(STAMP)
	for b in benchmarks/[!_]*.py; do echo "== $$b"; $(BIN)/python $$b || exit 1; done

clean:
	rm -rf $(VENV) build src/*.egg-info demo
