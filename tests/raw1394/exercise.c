/*
 * Drives libraw1394's API as FireWire host software does, against a bus of
 * memory boards (the test starts it): compiled against the system's
 * libraw1394 headers, run with fw1394's library in place. Prints "ok NAME"
 * per check, "FAIL NAME: why" and exit status 1 on the first failure.
 *
 * The test kills node 0 when the program says "kill node 0" and then sends a
 * line on stdin.
 */
#include <arpa/inet.h>
#include <errno.h>
#include <poll.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include <libraw1394/csr.h>
#include <libraw1394/raw1394.h>

#define OUTSTANDING 64
#define BASE 0x100 /* memory-board offset the checks use */
#define ARM_START 0xFFFF00000000ULL

static int resets;
static unsigned int last_generation;
static int tags_done, tags_ok, tags_again;
static quadlet_t buffers[OUTSTANDING];
static int fcp_seen;

#define CHECK(name, condition, ...)                                                   \
	do {                                                                          \
		if (!(condition)) {                                                   \
			printf("FAIL %s: ", name);                                    \
			printf(__VA_ARGS__);                                          \
			printf(" (errno %s)\n", strerror(errno));                     \
			exit(1);                                                      \
		}                                                                     \
		printf("ok %s\n", name);                                              \
		fflush(stdout);                                                       \
	} while (0)

static int on_reset(raw1394handle_t h, unsigned int generation)
{
	resets++;
	last_generation = generation;
	raw1394_update_generation(h, generation);
	return 0;
}

static int arm_calls;
static struct raw1394_arm_reqhandle arm_handle;

/* The written quadlet, as the request carried it, and the answer sent for it. */
static int on_arm(raw1394handle_t h, struct raw1394_arm_request_response *both,
		  unsigned int length, void *context, byte_t type)
{
	(void)h;
	if (type == RAW1394_ARM_WRITE && length == 4 && both->request->buffer_length == 4 &&
	    both->request->buffer[0] == 0x5E && both->response->response_code == 0 &&
	    both->request->destination_offset == ARM_START + 4)
		++*(int *)context;
	return 0;
}

/* Notes the reset but keeps the old generation, as a program that does not call
 * raw1394_update_generation. */
static int on_reset_kept(raw1394handle_t h, unsigned int generation)
{
	(void)h;
	resets++;
	last_generation = generation;
	return 0;
}

static int on_tag(raw1394handle_t h, unsigned long tag, raw1394_errcode_t err)
{
	int error = raw1394_errcode_to_errno(err);

	(void)h;
	tags_done++;
	if (!error && ntohl(buffers[tag]) == 0xC0DE0000u + tag)
		tags_ok++;
	else if (error == EAGAIN)
		tags_again++;
	return 0;
}

static int on_fcp(raw1394handle_t h, nodeid_t node, int response, size_t length,
		  unsigned char *data)
{
	(void)h;
	if (node == raw1394_get_local_id(h) && !response && length == 4 && data[0] == 0xA5)
		fcp_seen++;
	return 0;
}

static int streams;

static enum raw1394_iso_disposition on_stream(raw1394handle_t h, unsigned char *data,
					      unsigned int len, unsigned char channel,
					      unsigned char tag, unsigned char sy, unsigned int cycle,
					      unsigned int dropped)
{
	(void)h; (void)cycle; (void)dropped;
	if (len == 4 && channel == 9 && tag == 1 && sy == 2 && data[1] == 0x57)
		streams++;
	return RAW1394_ISO_OK;
}

/* Serve events until ``*counter`` reaches ``want`` or ``seconds`` pass. */
static int serve_until(raw1394handle_t h, int *counter, int want, int seconds)
{
	struct pollfd pfd = { raw1394_get_fd(h), POLLIN, 0 };
	time_t limit = time(NULL) + seconds;

	while (*counter < want && time(NULL) < limit) {
		if (poll(&pfd, 1, 100) > 0 && raw1394_loop_iterate(h) < 0)
			return -1;
	}
	return *counter >= want ? 0 : -1;
}

int main(void)
{
	struct raw1394_portinfo ports[4];
	raw1394handle_t h = raw1394_new_handle();
	quadlet_t value, block[OUTSTANDING], rom[256], old;
	size_t rom_size;
	unsigned char rom_version;
	u_int32_t cycle;
	u_int64_t local_time;
	int n, nodes, i, boards, before;
	char line[16];

	CHECK("new_handle", h != NULL, "no handle");
	CHECK("get_libversion", strcmp(raw1394_get_libversion(), "2.1.2") == 0, "%s",
	      raw1394_get_libversion());
	n = raw1394_get_port_info(h, ports, 4);
	CHECK("get_port_info", n >= 1 && ports[0].nodes >= 2, "%d ports", n);
	printf("port 0: %s, %d nodes\n", ports[0].name, ports[0].nodes);
	CHECK("set_port", raw1394_set_port(h, 0) == 0, "set_port failed");
	raw1394_set_bus_reset_handler(h, on_reset);
	nodes = raw1394_get_nodecount(h);
	boards = nodes - 1;
	CHECK("get_nodecount", nodes == ports[0].nodes, "%d != %d", nodes, ports[0].nodes);
	CHECK("get_local_id", (raw1394_get_local_id(h) & 0x3F) == nodes - 1, "local 0x%x",
	      raw1394_get_local_id(h));
	CHECK("get_irm_id", raw1394_get_irm_id(h) == raw1394_get_local_id(h), "irm 0x%x",
	      raw1394_get_irm_id(h));
	CHECK("get_speed", raw1394_get_speed(h, 0xFFC0) == RAW1394_ISO_SPEED_400, "speed");
	CHECK("get_fd", raw1394_get_fd(h) >= 0, "fd");
	CHECK("get_generation", raw1394_get_generation(h) > 0, "generation 0");
	last_generation = raw1394_get_generation(h);

	/* Blocking writes and reads on every board. */
	for (i = 0; i < OUTSTANDING; i++)
		block[i] = htonl(0xC0DE0000u + i);
	for (n = 0; n < boards; n++)
		if (raw1394_write(h, 0xFFC0 | n, BASE, sizeof block, block) < 0)
			break;
	CHECK("write", n == boards, "block write to node %d", n);
	value = 0;
	CHECK("read", raw1394_read(h, 0xFFC0, BASE + 8, 4, &value) == 0 &&
			      ntohl(value) == 0xC0DE0002u, "read 0x%08x", ntohl(value));
	CHECK("get_errcode", raw1394_errcode_to_errno(raw1394_get_errcode(h)) == 0, "0x%x",
	      raw1394_get_errcode(h));

	/* A request nobody answers: an address error, by the header's macros. */
	errno = 0;
	n = raw1394_read(h, 0xFFC0, 0x100000000ULL, 4, &value);
	CHECK("errcode address error", n < 0 &&
		      raw1394_get_rcode(raw1394_get_errcode(h)) == RAW1394_RCODE_ADDRESS_ERROR,
	      "errcode 0x%x", raw1394_get_errcode(h));

	/* Broadcast: one write, every board has it. */
	value = htonl(0xB0ADCA57u);
	CHECK("broadcast write", raw1394_write(h, 0xFFFF, BASE + 0x200, 4, &value) == 0,
	      "broadcast");
	for (n = 0; n < boards; n++) {
		quadlet_t got = 0;
		if (raw1394_read(h, 0xFFC0 | n, BASE + 0x200, 4, &got) < 0 ||
		    ntohl(got) != 0xB0ADCA57u)
			break;
	}
	CHECK("broadcast reached every node", n == boards, "node %d", n);

	/* 64 asynchronous reads outstanding at once, ended through the tag handler. */
	raw1394_set_tag_handler(h, on_tag);
	for (i = 0; i < OUTSTANDING; i++)
		if (raw1394_start_read(h, 0xFFC0, BASE + 4 * i, 4, &buffers[i], i) < 0)
			break;
	CHECK("start_read x64", i == OUTSTANDING, "start %d", i);
	CHECK("64 outstanding complete", serve_until(h, &tags_done, OUTSTANDING, 20) == 0 &&
		      tags_ok == OUTSTANDING, "%d done, %d ok", tags_done, tags_ok);
	/* Replies the library has read but not handled keep get_fd readable: after each
	 * loop_iterate, until every one is handled, however they came in. */
	tags_done = 0;
	for (i = 0; i < 8; i++)
		if (raw1394_start_read(h, 0xFFC0, BASE + 4 * i, 4, &buffers[i], i) < 0)
			break;
	for (n = 0; n < 8 && tags_done < 8; n++) {
		struct pollfd pfd = { raw1394_get_fd(h), POLLIN, 0 };
		if (poll(&pfd, 1, 5000) != 1 || raw1394_loop_iterate(h) < 0)
			break;
	}
	CHECK("get_fd readable while replies wait", i == 8 && tags_done == 8, "%d of %d handled",
	      tags_done, i);
	{
		struct pollfd pfd = { raw1394_get_fd(h), POLLIN, 0 };
		CHECK("get_fd quiet once they are handled", poll(&pfd, 1, 0) == 0, "readable");
	}
	tags_done = 0;
	CHECK("start_write", raw1394_start_write(h, 0xFFC0, BASE, 4, block, 0) == 0 &&
		      serve_until(h, &tags_done, 1, 10) == 0, "start_write");

	/* A bus reset while 64 reads are outstanding: each ends, done or EAGAIN. */
	tags_done = tags_ok = tags_again = 0;
	before = resets;
	for (i = 0; i < OUTSTANDING; i++)
		raw1394_start_read(h, 0xFFC0 | (i % boards), BASE + 4 * i, 4, &buffers[i], i);
	CHECK("reset_bus", raw1394_reset_bus(h) == 0, "reset");
	CHECK("transactions end across a reset", serve_until(h, &tags_done, OUTSTANDING, 30) == 0
		      && tags_ok + tags_again == OUTSTANDING, "%d done, %d ok, %d again",
	      tags_done, tags_ok, tags_again);
	printf("across the reset: %d completed, %d EAGAIN\n", tags_ok, tags_again);
	CHECK("bus reset handler", serve_until(h, &resets, before + 1, 15) == 0 &&
		      raw1394_get_generation(h) == last_generation, "resets %d", resets);

	/* A reset the program has not taken in: its requests are of an ended generation. */
	raw1394_set_bus_reset_handler(h, on_reset_kept);
	before = resets;
	CHECK("reset_bus_new", raw1394_reset_bus_new(h, RAW1394_SHORT_RESET) == 0, "reset");
	CHECK("reset seen, generation kept", serve_until(h, &resets, before + 1, 15) == 0 &&
		      raw1394_get_generation(h) != last_generation, "generation %u",
	      raw1394_get_generation(h));
	errno = 0;
	CHECK("stale generation fails", raw1394_read(h, 0xFFC0, BASE, 4, &value) < 0 &&
		      errno == EAGAIN, "read");
	raw1394_update_generation(h, last_generation);
	CHECK("update_generation", raw1394_read(h, 0xFFC0, BASE, 4, &value) == 0, "read");
	raw1394_set_bus_reset_handler(h, on_reset);

	/* The local node: CSR core, configuration ROM, FCP, a registered range. */
	value = htonl(0x1);
	CHECK("write STATE_CLEAR", raw1394_write(h, raw1394_get_local_id(h),
						 CSR_REGISTER_BASE + CSR_STATE_CLEAR, 4, &value) == 0,
	      "STATE_CLEAR");
	CHECK("get_config_rom", raw1394_get_config_rom(h, rom, sizeof rom, &rom_size,
						       &rom_version) == 0 && rom_size >= 20 &&
		      ntohl(rom[1]) == 0x31333934, "rom 0x%08x", ntohl(rom[1]));
	CHECK("read own config ROM", raw1394_read(h, raw1394_get_local_id(h),
						  CSR_REGISTER_BASE + CSR_CONFIG_ROM + 4, 4,
						  &value) == 0 && value == rom[1], "0x%08x", value);
	CHECK("update_config_rom", raw1394_update_config_rom(h, rom, rom_size, rom_version) == 0,
	      "update");
	CHECK("update_config_rom stale version",
	      raw1394_update_config_rom(h, rom, rom_size, rom_version) == -1, "accepted");
	CHECK("lock compare_swap", raw1394_lock(h, raw1394_get_local_id(h),
						CSR_REGISTER_BASE + CSR_CHANNELS_AVAILABLE_HI,
						RAW1394_EXTCODE_COMPARE_SWAP, htonl(0x7FFFFFFF),
						htonl(0xFFFFFFFF), &old) == 0 &&
		      ntohl(old) == 0xFFFFFFFF, "old 0x%08x", ntohl(old));
	raw1394_set_fcp_handler(h, on_fcp);
	CHECK("start_fcp_listen", raw1394_start_fcp_listen(h) == 0, "fcp");
	value = htonl(0xA5000000);
	raw1394_write(h, raw1394_get_local_id(h), CSR_REGISTER_BASE + CSR_FCP_COMMAND, 4, &value);
	CHECK("fcp handler", serve_until(h, &fcp_seen, 1, 10) == 0, "fcp %d", fcp_seen);
	CHECK("stop_fcp_listen", raw1394_stop_fcp_listen(h) == 0, "stop");
	arm_handle.arm_callback = on_arm;
	arm_handle.pcontext = &arm_calls;
	CHECK("arm_register", raw1394_arm_register(h, ARM_START, 16, (byte_t *)block,
						   (octlet_t)(unsigned long)&arm_handle,
						   RAW1394_ARM_READ | RAW1394_ARM_WRITE |
							   RAW1394_ARM_LOCK,
						   RAW1394_ARM_WRITE, 0) == 0,
	      "arm");
	CHECK("arm_register overlap refused", raw1394_arm_register(h, ARM_START + 8, 16, NULL, 0,
								   RAW1394_ARM_READ, 0, 0) < 0,
	      "overlap accepted");
	value = htonl(0x5EED5EED);
	CHECK("write own ARM range", raw1394_write(h, raw1394_get_local_id(h), ARM_START + 4, 4,
						   &value) == 0, "arm write");
	CHECK("arm_get_buf", raw1394_arm_get_buf(h, ARM_START + 4, 4, &old) == 0 && old == value,
	      "0x%08x", ntohl(old));
	CHECK("arm notification", arm_calls == 1, "%d calls", arm_calls);
	CHECK("lock own ARM range", raw1394_lock(h, raw1394_get_local_id(h), ARM_START + 8,
						 RAW1394_EXTCODE_FETCH_ADD, htonl(5), 0, &old) == 0 &&
		      old == block[2] && raw1394_arm_get_buf(h, ARM_START + 8, 4, &value) == 0 &&
		      ntohl(value) == ntohl(block[2]) + 5, "old 0x%08x", ntohl(old));
	value = htonl(0xFEED);
	CHECK("arm_set_buf", raw1394_arm_set_buf(h, ARM_START + 12, 4, &value) == 0 &&
		      raw1394_read(h, raw1394_get_local_id(h), ARM_START + 12, 4, &old) == 0 &&
		      old == value, "0x%08x", ntohl(old));
	CHECK("read own ARM range", raw1394_read(h, raw1394_get_local_id(h), ARM_START, 4,
						 &value) == 0 && value == block[0], "0x%08x",
	      ntohl(value));
	CHECK("arm_unregister", raw1394_arm_unregister(h, ARM_START) == 0, "unregister");
	CHECK("read_cycle_timer", raw1394_read_cycle_timer(h, &cycle, &local_time) == 0 &&
		      ((cycle >> 12) & 0x1FFF) < 8000 && (cycle & 0xFFF) < 3072, "0x%08x", cycle);
	CHECK("read_cycle_timer_and_clock", raw1394_read_cycle_timer_and_clock(
						    h, &cycle, &local_time, CLOCK_MONOTONIC) == 0,
	      "clock");
	CHECK("echo_request", raw1394_echo_request(h, 0x1234) == 0 &&
		      raw1394_loop_iterate(h) == 0x1234, "echo");
	errno = 0;
	CHECK("iso needs init", raw1394_iso_xmit_write(h, (unsigned char *)block, 8, 0, 0) < 0 &&
		      errno == EINVAL, "iso");
	CHECK("iso_recv_init", raw1394_iso_recv_init(h, on_stream, 8, 64, 9, RAW1394_DMA_DEFAULT,
						     1) == 0 &&
		      raw1394_iso_recv_start(h, -1, -1, 0) == 0, "iso recv");
	value = htonl(0x57AEA3);
	CHECK("async_stream", raw1394_async_stream(h, 9, 1, 2, RAW1394_ISO_SPEED_400, 4, &value) == 0
		      && serve_until(h, &streams, 1, 10) == 0, "streams %d", streams);
	raw1394_iso_shutdown(h);

	/* A node dies: its reads fail, the bus resets without it. */
	before = resets;
	printf("kill node 0\n");
	fflush(stdout);
	if (!fgets(line, sizeof line, stdin))
		return 1;
	errno = 0;
	CHECK("read from a dead node fails", raw1394_read(h, 0xFFC0, BASE, 4,
							  &value) < 0 && errno == EAGAIN,
	      "read");
	CHECK("reset after the death", serve_until(h, &resets, before + 1, 30) == 0 &&
		      raw1394_get_nodecount(h) == nodes - 1, "nodes %d", raw1394_get_nodecount(h));
	raw1394_destroy_handle(h);
	printf("done\n");
	return 0;
}
