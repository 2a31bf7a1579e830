# Two entry points: `make demo` and `make test`. Both set everything up from nothing.
VENV := .venv
BIN := $(VENV)/bin
DEMO_OUT := demo-output

.PHONY: setup demo test test-slow clean

setup: $(VENV)/.installed

$(VENV)/.installed: pyproject.toml package.json package-lock.json scripts/install-system-deps.sh
	bash scripts/install-system-deps.sh
	python3 -m venv $(VENV)
	$(BIN)/pip install --quiet -e '.[dev]'
	npm ci --no-audit --no-fund --loglevel=error
	touch $@

demo: setup
	for class in wood plastic metal; do \
		$(BIN)/make-materials --class $$class --count 2 --resolution 256 \
			--out $(DEMO_OUT)/materials --probe probes/park.exr --spp 64 \
			|| exit 1; \
	done
	@echo "Contact sheets: $(DEMO_OUT)/materials/contact_sheet_*.png"
	mkdir -p $(DEMO_OUT)/all-materials
	cp -r scenes/materials/*/ $(DEMO_OUT)/materials/*/ $(DEMO_OUT)/all-materials/
	$(BIN)/render-dataset --probes probes --svbrdfs $(DEMO_OUT)/all-materials \
		--out $(DEMO_OUT)/dataset --resolution 64 --render-size 128 --rotations 2 --crops 4 \
		--spp 256 --test-materials 0.34 --test-probes 0.34 --workers 2
	@echo "Contact sheet: $(DEMO_OUT)/dataset/contact_sheet.png"
	$(BIN)/sa-train --dataset $(DEMO_OUT)/dataset --unlabeled $(DEMO_OUT)/dataset \
		--probes probes --out $(DEMO_OUT)/train --network small --labeled-epochs 3 \
		--self-augmented-epochs 3 --log-every 10
	@echo "Loss curves, test examples with ground truth: $(DEMO_OUT)/train/{loss_curves,examples}.png"
	# sa-estimate and sa-evaluate continue a folder only with the same model and options: a
	# repeated demo (whose run above may have trained on) starts its estimates afresh
	rm -rf $(DEMO_OUT)/estimate-demo-run $(DEMO_OUT)/estimate $(DEMO_OUT)/evaluate
	$(BIN)/sa-estimate scenes/photos/brick-reference-01.jpg --model $(DEMO_OUT)/train \
		--out $(DEMO_OUT)/estimate-demo-run --probe probes/env-studio.exr
	$(BIN)/sa-estimate scenes/photos/brick-reference-01.jpg --out $(DEMO_OUT)/estimate
	@echo "The default estimate: $(DEMO_OUT)/estimate/report.html"
	$(BIN)/sa-evaluate --materials scenes/materials --probes probes \
		--samples 4 --relights 2 --out $(DEMO_OUT)/evaluate
	@echo "Estimates against the truth and the naive baseline (the bundled sets are not a held-out test; real-set validation and test figures: models/README.md): $(DEMO_OUT)/evaluate/figure.png"
	$(BIN)/check-renderer --probes probes --svbrdfs scenes/materials --size 64 \
		--out $(DEMO_OUT)/check-renderer
	@echo "Mitsuba | torch | 10x difference: $(DEMO_OUT)/check-renderer/*.png"

test: setup
	$(BIN)/python -m pytest -q -m "not slow"

test-slow: setup
	$(BIN)/python -m pytest -q -m slow

clean:
	rm -rf $(VENV) $(DEMO_OUT)
