# The two README commands: `make demo` and `make test`. Both do all set-up first.
.PHONY: setup demo test bench extension wheels clean

setup:
	@bash scripts/setup.sh

demo: setup
	.venv/bin/python scripts/demo.py --out out/demo

test: setup
	bash scripts/test.sh $(PYTEST_ARGS)

bench: setup
	.venv/bin/python -m bench --out out/bench $(BENCH_ARGS)

# Download the wheels the extension manifest lists (not committed), then build the zip.
wheels: setup
	.venv/bin/python scripts/extension.py wheels

extension: wheels
	.venv/bin/python scripts/extension.py build --out dist

clean:
	rm -rf out dist .pytest_cache
