# activeskin: two commands on a fresh Debian/Ubuntu machine.
#   make demo   installs what is missing, builds, runs the built-in demo, writes ./out
#   make test   installs what is missing, then runs the whole test suite
CARGO ?= cargo
OUT ?= out

.PHONY: all deps build demo test bench lint clean

all: build

deps:
	@bash .ci/deps

build: deps
	$(CARGO) build --release

demo: build
	@mkdir -p $(OUT)
	./target/release/activeskin demo --out $(OUT)
	./target/release/activeskin info $(OUT)/fig7/fig7.0048.vdb
	@echo "demo: Fig. 7 morph (six blobs to two spheres) in ./$(OUT): fig7.####.vdb and fig7.####.obj"

bench: deps
	$(CARGO) bench --bench step

# Tests run optimised: they solve and mesh real grids.
test: deps
	$(CARGO) test --release
	$(MAKE) lint

lint:
	$(CARGO) fmt --all -- --check
	$(CARGO) clippy --release --all-targets -- -D warnings

clean:
	$(CARGO) clean
	rm -rf $(OUT)
