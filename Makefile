# hdnet: plain Makefile. `make` builds libhdnet.a and the hdnet tool; `make test` runs every test;
# `make check` runs the tests under AddressSanitizer + UndefinedBehaviorSanitizer; `make bench`
# prints the benchmark figures; `make demo` runs the main job on the bundled examples.

CC      ?= cc
PREFIX  ?= /usr/local
ARCH    ?= -march=x86-64-v3
OPT     ?= -O2
CFLAGS  ?= $(OPT) $(ARCH)
CFLAGS  += -std=c11 -D_POSIX_C_SOURCE=200809L -D_DEFAULT_SOURCE -Wall -Wextra -fopenmp -Iinclude -Isrc
LDLIBS  += -lpng -ljpeg -lz -lcjson -lopenblas -lm -fopenmp -lpthread
# oneDNN is the fast convolution path; `make HD_DNNL=0` builds the portable path only.
HD_DNNL ?= $(shell test -f /usr/include/dnnl.h && echo 1 || echo 0)
ifeq ($(HD_DNNL),1)
CFLAGS  += -DHD_HAVE_DNNL=1
LDLIBS  += -ldnnl
endif

# Open MPI makes `mpirun -np R hdnet train` data-parallel (docs/scaling.md); the tool alone links
# it, the library knows nothing of MPI. `make HD_MPI=0` builds without it.
HD_MPI  ?= $(shell command -v mpicc >/dev/null 2>&1 && echo 1 || echo 0)
ifeq ($(HD_MPI),1)
MPI_CFLAGS := -DHD_HAVE_MPI=1 $(shell mpicc --showme:compile)
MPI_LIBS   := $(shell mpicc --showme:link)
endif

BUILD   ?= build
SRC     := $(sort $(wildcard src/*/*.c))
OBJ     := $(SRC:%.c=$(BUILD)/%.o)
TOOLSRC := $(sort $(wildcard tools/*.c))
TOOLOBJ := $(TOOLSRC:%.c=$(BUILD)/%.o)
TESTSRC := $(sort $(wildcard tests/test_*.c))
TESTBIN := $(TESTSRC:tests/%.c=$(BUILD)/tests/%)
# Every object and test depends on the headers it includes (gcc -MMD -MP writes BUILD/...d beside it).
DEPFLAGS = -MMD -MP

all: hdnet

# ./hdnet points at the default build only (other BUILD folders leave it alone).
hdnet: $(BUILD)/hdnet
	if [ "$(BUILD)" = build ]; then ln -sf build/hdnet hdnet; fi

$(BUILD)/libhdnet.a: $(OBJ)
	@mkdir -p $(dir $@)
	rm -f $@ && ar rcs $@ $^

# A build folder from before the .d files is rebuilt once (the stamp is newer than its objects).
$(BUILD)/.deps-mmd:
	@mkdir -p $(dir $@)
	touch $@

$(BUILD)/%.o: %.c $(BUILD)/.deps-mmd
	@mkdir -p $(dir $@)
	$(CC) $(CFLAGS) $(DEPFLAGS) -I$(BUILD) -c $< -o $@

# Only the tool sees MPI.
$(TOOLOBJ): CFLAGS += $(MPI_CFLAGS)

# Only the dispatcher includes the generated command list.
$(BUILD)/tools/main.o: $(BUILD)/commands.inc

# Every tools/cmd_*.c registers itself with a line HD_COMMAND("name", fn, "summary").
$(BUILD)/commands.inc: $(TOOLSRC)
	@mkdir -p $(dir $@)
	cat /dev/null $(wildcard tools/cmd_*.c) | grep '^HD_COMMAND(' > $@.tmp; cmp -s $@.tmp $@ && rm $@.tmp || mv $@.tmp $@

$(BUILD)/hdnet: $(TOOLOBJ) $(BUILD)/libhdnet.a
	$(CC) -o $@ $(TOOLOBJ) $(BUILD)/libhdnet.a $(LDFLAGS) $(LDLIBS) $(MPI_LIBS)

$(BUILD)/tests/%: tests/%.c $(BUILD)/libhdnet.a $(BUILD)/.deps-mmd
	@mkdir -p $(dir $@)
	$(CC) $(CFLAGS) $(DEPFLAGS) -MF $@.d -Itests -I$(BUILD) -o $@ $< $(BUILD)/libhdnet.a $(LDFLAGS) $(LDLIBS)

$(BUILD)/tests/test_header_example: $(BUILD)/header_example.inc

# The usage example in the opening comment of include/hdnet.h, extracted so a test compiles and runs it.
$(BUILD)/header_example.inc: include/hdnet.h
	@mkdir -p $(dir $@)
	sed -n '/^ \* Example/,/^ \*\//p' $< | sed -e '1d' -e '$$d' -e 's/^ \*     //' -e 's/^ \*$$//' | grep -v '^#include' > $@.tmp && mv $@.tmp $@

tests: $(TESTBIN) $(BUILD)/hdnet

-include $(OBJ:.o=.d) $(TOOLOBJ:.o=.d) $(TESTBIN:=.d)

# Runs each C test, then each shell test (which drive the built hdnet tool), all of them, ending with
# "N passed, N failed" (and a nonzero status if any failed).
test: tests
	@HDNET=$(abspath $(BUILD)/hdnet) BUILD=$(abspath $(BUILD)) sh tests/run.sh $(abspath $(TESTBIN))

check:
	$(MAKE) BUILD=build-check OPT="-O1 -g -fno-omit-frame-pointer -fsanitize=address,undefined -fno-sanitize-recover=all" \
	    LDFLAGS="-fsanitize=address,undefined" HD_CHECK=1 test

# The Debian/Ubuntu packages the build needs (through sudo unless already root).
DEPS := gcc make libpng-dev libjpeg-dev zlib1g-dev libopenblas-dev libdnnl-dev libcjson-dev
deps:
	@if dpkg -s $(DEPS) >/dev/null 2>&1; then echo "deps: all installed"; else \
	    SUDO=$$([ "$$(id -u)" = 0 ] || echo sudo); \
	    $$SUDO apt-get update && $$SUDO apt-get install -y --no-install-recommends $(DEPS); fi

# Data-parallel training on MPI against the single-process run (tests/mpi/train.sh; needs
# mpirun and Debian's python3 with numpy). Slow on a busy machine: its own target, which CI calls.
test-mpi: $(BUILD)/hdnet
	@d=$$(mktemp -d "$${TMPDIR:-/tmp}/hdnet-mpi.XXXXXX") && cd "$$d" && \
	    HDNET=$(abspath $(BUILD)/hdnet) sh $(abspath tests/mpi/train.sh); rc=$$?; rm -rf "$$d"; exit $$rc

bench: hdnet
	./hdnet bench

demo: hdnet
	sh examples/demo.sh

install: hdnet
	install -d $(DESTDIR)$(PREFIX)/bin $(DESTDIR)$(PREFIX)/lib $(DESTDIR)$(PREFIX)/include $(DESTDIR)$(PREFIX)/lib/pkgconfig $(DESTDIR)$(PREFIX)/share/hdnet
	install -m 755 $(BUILD)/hdnet $(DESTDIR)$(PREFIX)/bin/hdnet
	install -m 644 $(BUILD)/libhdnet.a $(DESTDIR)$(PREFIX)/lib/libhdnet.a
	install -m 644 include/hdnet.h $(DESTDIR)$(PREFIX)/include/hdnet.h
	sed -e 's|@PREFIX@|$(PREFIX)|' -e 's|@LIBS@|$(LDLIBS)|' hdnet.pc.in > $(DESTDIR)$(PREFIX)/lib/pkgconfig/hdnet.pc
	if [ -d models ]; then cp -r models/. $(DESTDIR)$(PREFIX)/share/hdnet/; fi

clean:
	rm -rf build build-check hdnet

.PHONY: all hdnet tests test check test-mpi bench demo install clean deps
.SECONDARY:
