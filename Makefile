# Two entry points: `make demo` and `make test`. Both set everything up from nothing.
VENV := .venv
BIN := $(VENV)/bin
DEMO_OUT := demo-output

.PHONY: setup demo test clean

setup: $(VENV)/.installed

$(VENV)/.installed: pyproject.toml scripts/install-system-deps.sh
	bash scripts/install-system-deps.sh
	python3 -m venv $(VENV)
	$(BIN)/pip install --quiet -e '.[dev]'
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
		--out $(DEMO_OUT)/dataset --resolution 128 --render-size 192 --rotations 2 --crops 2 \
		--workers 2
	@echo "Contact sheet: $(DEMO_OUT)/dataset/contact_sheet.png"
	$(BIN)/check-renderer --probes probes --svbrdfs scenes/materials --size 64 \
		--out $(DEMO_OUT)/check-renderer
	@echo "Mitsuba | torch | 10x difference: $(DEMO_OUT)/check-renderer/*.png"

test: setup
	$(BIN)/python -m pytest -q

clean:
	rm -rf $(VENV) $(DEMO_OUT)
