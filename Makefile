# activeskin: two commands on a fresh Debian/Ubuntu machine.
#   make demo   installs what is missing, builds, runs the built-in demo, writes ./out
#   make test   installs what is missing, then runs the whole test suite
CARGO ?= cargo
OUT ?= out

.PHONY: all deps build demo test lint clean

all: build

deps:
	@bash .ci/deps

build: deps
	$(CARGO) build --release

demo: build
	@mkdir -p $(OUT)
	$(CARGO) run --release --example sphere -- $(OUT)/sphere.vdb
	./target/release/activeskin info $(OUT)/sphere.vdb
	@echo "demo output written to ./$(OUT)"

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
