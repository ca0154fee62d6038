/*
 * libraw1394.so.11 for fw1394's virtual bus.
 *
 * Every call becomes a message of the bus's host-adapter protocol
 * (docs/host-adapter.md) on the adapter's Unix socket; the adapter runs the
 * transactions and serves the local node. This file only marshals: it keeps
 * what a handle must remember between calls (outstanding requests, handlers,
 * the memory behind address ranges the program registered) and nothing of
 * the bus's behaviour.
 *
 * Where it finds the bus: FW1394_ADAPTER (the socket) and FW1394_BUS (its
 * name), as `fw1394 run` sets them; other buses of this user are further ports,
 * found in $XDG_RUNTIME_DIR/fw1394 (or /tmp/fw1394-UID).
 */
#define _GNU_SOURCE
#include <dirent.h>
#include <errno.h>
#include <fcntl.h>
#include <poll.h>
#include <stdarg.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/epoll.h>
#include <sys/eventfd.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <sys/time.h>
#include <sys/un.h>
#include <time.h>
#include <unistd.h>

#include <libraw1394/csr.h>
#include <libraw1394/raw1394.h>

#define LIBVERSION "2.1.2"
#define MAX_PORTS 16
#define MAX_MESSAGE (1u << 17)

/* Adapter protocol operations (fw1394.transport.host_adapter.protocol.Op). */
enum op { OP_INFO, OP_READ, OP_WRITE, OP_LOCK, OP_SEND, OP_HELLO, OP_WATCH, OP_LISTEN,
	  OP_UNLISTEN, OP_RESPOND, OP_CYCLE_TIME, OP_CONFIG_ROM, OP_RESET, OP_ISO_SEND,
	  OP_ISO_LISTEN, OP_ADD_DESCRIPTOR, OP_REMOVE_DESCRIPTOR };
enum status { ST_OK, ST_FAILED, ST_REFUSED, ST_STALE };
/* The protocol version this library speaks. */
#define PROTOCOL_VERSION 2

/* Internal error codes (negative errcodes), as the raw1394 kernel interface numbered them. */
#define ERR_GENERATION (-1001)
#define ERR_SEND (-1002)
#define ERR_ABORTED (-1003)
#define ERR_TIMEOUT (-1004)
#define ERR_REFUSED (-1005)

#define ACK_COMPLETE 1
#define ACK_PENDING 2
/* One stream packet per channel per 125 us cycle, as on a 1394 bus. */
#define CYCLE_NS 125000L

enum iso_mode { ISO_OFF, ISO_XMIT, ISO_RECV };

struct iso {
	enum iso_mode mode;
	int started;
	raw1394_iso_xmit_handler_t xmit;
	raw1394_iso_recv_handler_t recv;
	unsigned int channel, max_packet;
	uint64_t mask;
	uint32_t listen;	/* the iso_listen request whose pushes are packets */
	struct timespec next;	/* when the next packet may go out */
	unsigned char *packet;	/* xmit handler's buffer */
};

/* How an outstanding request ends. */
enum kind { K_TAG, K_WAIT, K_DISCARD };

struct pending {
	uint32_t number;
	enum kind kind;
	int op;
	unsigned long tag;
	void *result;		/* read data or old lock value go here */
	size_t length;
	int done;
	raw1394_errcode_t errcode;
	unsigned char *data;	/* K_WAIT: the reply's data and header */
	size_t data_length;
	unsigned int generation;
	int phy;
	struct pending *next;
};

struct arm {
	nodeaddr_t start;
	size_t length;
	byte_t *memory;
	octlet_t tag;
	arm_options_t access, notify;
	uint32_t number;
	struct arm *next;
};

struct port {
	char name[32];
	char path[sizeof(((struct sockaddr_un *)0)->sun_path)];
};

struct reply {
	uint32_t request;
	int status;
	uint32_t generation;
	int phy;
	int ack, rcode;
	char reason[256];
	const unsigned char *data;
	uint32_t data_length;
};

struct raw1394_handle {
	int sock, epoll, event;
	struct port ports[MAX_PORTS];
	int port_count;
	unsigned int generation;
	int phy, nodes, irm;
	int notify;
	uint32_t numbers, watch, fcp;
	bus_reset_handler_t reset_handler;
	tag_handler_t tag_handler;
	arm_tag_handler_t arm_tag_handler;
	fcp_handler_t fcp_handler;
	void *userdata;
	raw1394_errcode_t err;
	struct pending *pending;
	struct arm *arms;
	unsigned char *in;
	size_t in_length, in_capacity;
	quadlet_t *echoes;
	size_t echo_count;
	int woken;
	int signalled;	/* the eventfd is readable (this library made it so) */
	int broken;	/* the connection failed: waits end */
	struct iso iso;
};

static void say_once(int *said, const char *what)
{
	if (!*said) {
		fprintf(stderr, "libraw1394 (fw1394): %s\n", what);
		*said = 1;
	}
}

static int fail(int error)
{
	errno = error;
	return -1;
}

static int broken(raw1394handle_t h, int error)
{
	h->broken = 1;
	return fail(error);
}

/* ---- big-endian fields ------------------------------------------------------------ */

static void put16(unsigned char *p, uint16_t v) { p[0] = v >> 8; p[1] = v; }
static void put32(unsigned char *p, uint32_t v) { put16(p, v >> 16); put16(p + 2, v); }
static void put64(unsigned char *p, uint64_t v) { put32(p, v >> 32); put32(p + 4, v); }
static uint16_t get16(const unsigned char *p) { return p[0] << 8 | p[1]; }
static uint32_t get32(const unsigned char *p) { return (uint32_t)get16(p) << 16 | get16(p + 2); }
static uint64_t get64(const unsigned char *p) { return (uint64_t)get32(p) << 32 | get32(p + 4); }

/* ---- messages --------------------------------------------------------------------- */

struct request {
	int op, node, extended_tcode, quadlet;
	uint32_t generation;
	uint64_t offset;
	uint32_t length;
	const void *argument, *data;
	size_t argument_length, data_length;
};

static void take_waiting(raw1394handle_t h);

/* Send all of ``p``. While the adapter cannot take more, take what it sends (unhandled):
 * it may be waiting to send before it reads again. */
static int write_all(raw1394handle_t h, const unsigned char *p, size_t n)
{
	while (n) {
		ssize_t done = send(h->sock, p, n, MSG_NOSIGNAL | MSG_DONTWAIT);
		if (done < 0) {
			struct pollfd pfd = { h->sock, POLLIN | POLLOUT, 0 };

			if (errno == EINTR)
				continue;
			if (errno != EAGAIN && errno != EWOULDBLOCK)
				return -1;
			if (poll(&pfd, 1, -1) < 0 && errno != EINTR)
				return -1;
			if (pfd.revents & POLLIN)
				take_waiting(h);
			continue;
		}
		p += done;
		n -= done;
	}
	return 0;
}

/* Send a request; its number, or 0 (errno set). */
static uint32_t put_request(raw1394handle_t h, const struct request *r)
{
	size_t head = 4 + 1 + 1 + 2 + 4 + 8 + 4 + 1 + 4;
	size_t body = head + 4 + r->argument_length + 4 + r->data_length;
	unsigned char small[256], *m, *p;
	uint32_t number;
	int result;

	if (h->sock < 0) {
		errno = ENOTCONN;
		return 0;
	}
	if (body > MAX_MESSAGE) {
		errno = EINVAL;
		return 0;
	}
	/* A transaction's request fits on the stack; a large block or ROM goes to the heap. */
	m = 4 + body <= sizeof small ? small : malloc(4 + body);
	if (!m)
		return 0;
	number = ++h->numbers;
	if (!number)
		number = ++h->numbers;
	p = m;
	put32(p, body); p += 4;
	put32(p, number); p += 4;
	*p++ = r->op;
	*p++ = r->node;
	put16(p, r->extended_tcode); p += 2;
	put32(p, r->generation); p += 4;
	put64(p, r->offset); p += 8;
	put32(p, r->length); p += 4;
	*p++ = r->quadlet;
	put32(p, 0); p += 4; /* wait: only raw sends listen */
	put32(p, r->argument_length); p += 4;
	if (r->argument_length)
		memcpy(p, r->argument, r->argument_length);
	p += r->argument_length;
	put32(p, r->data_length); p += 4;
	if (r->data_length)
		memcpy(p, r->data, r->data_length);
	result = write_all(h, m, 4 + body);
	if (m != small)
		free(m);
	return result < 0 ? 0 : number;
}

static int parse_reply(const unsigned char *b, size_t n, struct reply *r)
{
	size_t at = 0, reason, detail;

	if (n < 4 + 1 + 4 + 1 + 1 + 1 + 1 + 1)
		return -1;
	r->request = get32(b);
	r->status = b[4];
	r->generation = get32(b + 5);
	r->phy = b[9];
	r->ack = (signed char)b[10];
	r->rcode = (signed char)b[11];
	at = 13;
	reason = b[at++];
	if (at + reason + 2 > n)
		return -1;
	memcpy(r->reason, b + at, reason);
	r->reason[reason] = 0;
	at += reason;
	detail = get16(b + at);
	at += 2 + detail;
	if (at + 4 > n)
		return -1;
	r->data_length = get32(b + at);
	at += 4;
	if (at + r->data_length > n)
		return -1;
	r->data = b + at;
	return 0;
}

/* ---- outstanding requests ------------------------------------------------------------ */

static struct pending *add_pending(raw1394handle_t h, uint32_t number, enum kind kind, int op)
{
	struct pending *p = calloc(1, sizeof *p);

	if (!p)
		return NULL;
	p->number = number;
	p->kind = kind;
	p->op = op;
	p->next = h->pending;
	h->pending = p;
	return p;
}

static struct pending *take_pending(raw1394handle_t h, uint32_t number)
{
	struct pending **at;

	for (at = &h->pending; *at; at = &(*at)->next) {
		if ((*at)->number == number) {
			struct pending *p = *at;
			*at = p->next;
			return p;
		}
	}
	return NULL;
}

static raw1394_errcode_t errcode_of(const struct reply *r, int op)
{
	static const struct { const char *reason; raw1394_errcode_t code; } reasons[] = {
		{ "ack_type_error", 0xE << 16 },
		{ "ack_data_error", 0xD << 16 },
		{ "ack_address_error", 0xF << 16 },
		{ "ack_conflict_error", 0xC << 16 },
		{ "busy_retries_exhausted", 0x4 << 16 },
		{ "bus_reset", ERR_GENERATION },
		{ "no_ack", ERR_SEND },
		{ "response_timeout", ERR_TIMEOUT },
	};
	size_t i;

	if (r->status == ST_OK)
		return raw1394_make_errcode(op == OP_WRITE || op == OP_ISO_SEND ? ACK_COMPLETE :
					    ACK_PENDING, 0);
	if (r->status == ST_REFUSED)
		return ERR_REFUSED;
	if (r->status == ST_STALE)
		return ERR_GENERATION;
	if (r->rcode >= 0)
		return raw1394_make_errcode(ACK_PENDING, r->rcode);
	for (i = 0; i < sizeof reasons / sizeof *reasons; i++)
		if (!strcmp(r->reason, reasons[i].reason))
			return reasons[i].code;
	return ERR_ABORTED;
}

/* ---- events the adapter pushes -------------------------------------------------------- */

static int bus_state(raw1394handle_t h, const struct reply *r)
{
	h->phy = r->phy;
	if (r->data_length >= 2) {
		h->nodes = r->data[0];
		h->irm = r->data[1];
	}
	if (h->notify && h->reset_handler)
		return h->reset_handler(h, r->generation);
	return 0;
}

struct incoming {
	uint32_t handle;
	int tcode, tlabel, extended_tcode;
	nodeid_t source, destination;
	uint64_t offset;
	uint32_t length;
	const unsigned char *data;
	size_t data_length;
};

static int parse_incoming(const struct reply *r, struct incoming *in)
{
	const unsigned char *b = r->data;

	if (r->data_length < 24)
		return -1;
	in->handle = get32(b);
	in->tcode = b[4];
	in->tlabel = b[5];
	in->extended_tcode = get16(b + 6);
	in->source = get16(b + 8);
	in->destination = get16(b + 10);
	in->offset = get64(b + 12);
	in->length = get32(b + 20);
	in->data = b + 24;
	in->data_length = r->data_length - 24;
	return 0;
}

static int fcp_event(raw1394handle_t h, const struct reply *r)
{
	struct incoming in;

	if (parse_incoming(r, &in) < 0 || !h->fcp_handler)
		return 0;
	return h->fcp_handler(h, in.source,
			      in.offset >= CSR_REGISTER_BASE + CSR_FCP_RESPONSE,
			      in.data_length, (unsigned char *)in.data);
}

static void respond(raw1394handle_t h, uint32_t handle, int rcode, const void *data, size_t n)
{
	struct request q = { .op = OP_RESPOND, .offset = handle, .extended_tcode = rcode,
			     .data = data, .data_length = n };
	uint32_t number = put_request(h, &q);

	/* The adapter confirms every answer; nobody waits for that. */
	if (number)
		add_pending(h, number, K_DISCARD, OP_RESPOND);
}

static uint64_t load(const byte_t *p, size_t n)
{
	return n == 4 ? get32(p) : get64(p);
}

static void store(byte_t *p, size_t n, uint64_t v)
{
	if (n == 4)
		put32(p, v);
	else
		put64(p, v);
}

static uint64_t little(uint64_t v, size_t n)
{
	uint64_t out = 0;
	size_t i;

	for (i = 0; i < n; i++)
		out |= ((v >> (8 * i)) & 0xFF) << (8 * (n - 1 - i));
	return out;
}

/* The new value of a lock on memory holding ``old``; -1 for an unknown kind. */
static int lock_value(int code, size_t n, uint64_t old, uint64_t arg, uint64_t data, uint64_t *out)
{
	switch (code) {
	case RAW1394_EXTCODE_MASK_SWAP: *out = (old & ~arg) | (data & arg); return 0;
	case RAW1394_EXTCODE_COMPARE_SWAP: *out = old == arg ? data : old; return 0;
	case RAW1394_EXTCODE_FETCH_ADD: *out = old + data; return 0;
	case RAW1394_EXTCODE_LITTLE_ADD:
		*out = little(little(old, n) + little(data, n), n);
		return 0;
	case RAW1394_EXTCODE_BOUNDED_ADD: *out = old != arg ? old + data : old; return 0;
	case RAW1394_EXTCODE_WRAP_ADD: *out = old != arg ? old + data : data; return 0;
	}
	return -1;
}

static int request_type(int tcode)
{
	if (tcode == 4 || tcode == 5)
		return RAW1394_ARM_READ;
	if (tcode == 0 || tcode == 1)
		return RAW1394_ARM_WRITE;
	return RAW1394_ARM_LOCK;
}

/* Serve a request into a registered range from its memory, as the kernel's ARM did. */
static int arm_event(raw1394handle_t h, struct arm *arm, const struct reply *r)
{
	struct incoming in;
	int type, rcode = RAW1394_RCODE_COMPLETE, result = 0;
	size_t at, size = 0, answer_length = 0;
	unsigned char answer[8];
	const unsigned char *answer_data = NULL;

	if (parse_incoming(r, &in) < 0)
		return 0;
	type = request_type(in.tcode);
	at = in.offset - arm->start;
	if (type == RAW1394_ARM_LOCK) {
		int two = in.extended_tcode != RAW1394_EXTCODE_FETCH_ADD &&
			  in.extended_tcode != RAW1394_EXTCODE_LITTLE_ADD;
		size = two ? in.data_length / 2 : in.data_length;
	} else {
		size = type == RAW1394_ARM_READ ? in.length : in.data_length;
	}
	if (!(arm->access & type)) {
		rcode = RAW1394_RCODE_TYPE_ERROR;
	} else if (at + size > arm->length) {
		rcode = RAW1394_RCODE_ADDRESS_ERROR;
	} else if (type == RAW1394_ARM_READ) {
		answer_data = arm->memory + at;
		answer_length = size;
	} else if (type == RAW1394_ARM_WRITE) {
		memcpy(arm->memory + at, in.data, size);
	} else if (size != 4 && size != 8) {
		rcode = RAW1394_RCODE_TYPE_ERROR;
	} else {
		uint64_t old = load(arm->memory + at, size), new_value;
		uint64_t arg = size == in.data_length ? 0 : load(in.data, size);
		uint64_t data = load(in.data + in.data_length - size, size);

		if (lock_value(in.extended_tcode, size, old, arg, data, &new_value) < 0) {
			rcode = RAW1394_RCODE_TYPE_ERROR;
		} else {
			store(arm->memory + at, size, new_value);
			store(answer, size, old);
			answer_data = answer;
			answer_length = size;
		}
	}
	/* A broadcast (handle 0) is answered by nobody. */
	if (in.handle)
		respond(h, in.handle, rcode, answer_data, answer_length);
	if ((arm->notify & type) && h->arm_tag_handler) {
		struct raw1394_arm_request request = {
			.destination_nodeid = in.destination,
			.source_nodeid = in.source,
			.destination_offset = in.offset,
			.tlabel = in.tlabel,
			.tcode = in.tcode,
			.extended_transaction_code = in.extended_tcode,
			.generation = r->generation,
			.buffer_length = in.data_length,
			.buffer = (byte_t *)in.data,
		};
		struct raw1394_arm_response response = {
			.response_code = rcode,
			.buffer_length = answer_length,
			.buffer = (byte_t *)answer_data,
		};
		struct raw1394_arm_request_response both = { &request, &response };

		result = h->arm_tag_handler(h, arm->tag, type, size, &both);
	}
	return result;
}

static void iso_stop_receiving(raw1394handle_t h);

/* A stream packet on a channel this handle listens to. */
static int iso_event(raw1394handle_t h, const struct reply *r)
{
	enum raw1394_iso_disposition disposition;

	if (r->data_length < 6 || !h->iso.recv || !h->iso.started)
		return 0;
	disposition = h->iso.recv(h, (unsigned char *)r->data + 6, r->data_length - 6,
				  r->data[0], r->data[1], r->data[2], get16(r->data + 4), 0);
	if (disposition == RAW1394_ISO_ERROR)
		return -1;
	if (disposition == RAW1394_ISO_STOP)
		iso_stop_receiving(h);
	return 0;
}

/* One message from the adapter: whatever it ends or announces. */
static int dispatch(raw1394handle_t h, const struct reply *r)
{
	struct pending *p;
	struct arm *arm;

	if (r->request == h->watch && h->watch)
		return bus_state(h, r);
	if (r->request == h->fcp && h->fcp)
		return fcp_event(h, r);
	if (r->request == h->iso.listen && h->iso.listen)
		return iso_event(h, r);
	for (arm = h->arms; arm; arm = arm->next)
		if (arm->number == r->request && r->status == ST_OK && r->data_length >= 24)
			return arm_event(h, arm, r);
	p = take_pending(h, r->request);
	if (!p)
		return 0;
	p->errcode = errcode_of(r, p->op);
	if (r->status == ST_OK && p->result)
		memcpy(p->result, r->data, r->data_length < p->length ? r->data_length : p->length);
	if (p->kind == K_WAIT) {
		/* The waiter holds ``p``; it is off the list now. */
		p->done = 1;
		p->generation = r->generation;
		p->phy = r->phy;
		if (r->data_length && !p->result) { /* with a result buffer, the data is there */
			p->data = malloc(r->data_length);
			if (p->data) {
				memcpy(p->data, r->data, r->data_length);
				p->data_length = r->data_length;
			}
		}
		return 0;
	}
	if (p->kind == K_DISCARD) {
		free(p);
		return 0;
	}
	h->err = p->errcode;
	{
		unsigned long tag = p->tag;
		raw1394_errcode_t code = p->errcode;

		free(p);
		return h->tag_handler ? h->tag_handler(h, tag, code) : 0;
	}
}

/* The pollable fd is readable exactly while loop_iterate has something to do without
 * waiting: a message from the adapter, or one already buffered, an echo or a wake-up. */
static void signal_pending(raw1394handle_t h)
{
	uint64_t count;
	int buffered = h->in_length >= 4 && h->in_length >= 4 + get32(h->in);
	int saved = errno; /* a call that succeeds leaves errno as it found it */

	int wanted = buffered || h->echo_count || h->woken || (h->iso.started && h->iso.xmit);

	/* Most replies change nothing: the eventfd is touched only when it must change. */
	if (h->event < 0 || wanted == h->signalled)
		return;
	while (read(h->event, &count, sizeof count) > 0)
		;
	h->signalled = 0;
	if (wanted) {
		count = 1;
		h->signalled = write(h->event, &count, sizeof count) == sizeof count;
	}
	errno = saved;
}

static int iso_pump(raw1394handle_t h);

/* ---- waiting for a reply -------------------------------------------------------------
 *
 * A blocking call sleeps in poll until its reply comes: it does not spin. On a
 * machine with fewer cores than the processes of a transaction (the program, the
 * adapter, the node), a spinning program takes the CPU from the adapter or the node
 * that is to answer it. loop_iterate sleeps in poll on the socket and the eventfd. */

/*
 * Handle one message (waiting for it if need be). ``user``: also return echoes
 * and wake-ups, as raw1394_loop_iterate does; internal waits leave those queued.
 */
static int iterate(raw1394handle_t h, int user)
{
	for (;;) {
		if (user && h->echo_count) {
			quadlet_t value = h->echoes[0];
			memmove(h->echoes, h->echoes + 1, --h->echo_count * sizeof *h->echoes);
			signal_pending(h);
			return (int)value;
		}
		if (user && h->woken) {
			h->woken = 0;
			signal_pending(h);
			return 0;
		}
		if (user && h->iso.started && h->iso.xmit)
			return iso_pump(h);
		if (h->in_length >= 4) {
			uint32_t size = get32(h->in);
			struct reply r;
			int result, parsed;

			if (size > MAX_MESSAGE)
				return broken(h, EPROTO);
			if (h->in_length >= 4 + size) {
				/* Out of the buffer first: a handler may call the library, which
				 * reads into it. A transaction's reply fits on the stack. */
				unsigned char small[512];
				unsigned char *body = size <= sizeof small ? small : malloc(size);
				if (!body)
					return broken(h, ENOMEM);
				memcpy(body, h->in + 4, size);
				memmove(h->in, h->in + 4 + size, h->in_length - 4 - size);
				h->in_length -= 4 + size;
				parsed = parse_reply(body, size, &r) == 0;
				result = parsed ? dispatch(h, &r) : 0;
				if (body != small)
					free(body);
				if (!parsed)
					return broken(h, EPROTO);
				signal_pending(h);
				return result;
			}
		}
		{
			struct pollfd fds[2] = { { h->sock, POLLIN, 0 }, { h->event, POLLIN, 0 } };
			ssize_t got;

			if (h->sock < 0)
				return broken(h, ENOTCONN);
			if (h->in_capacity - h->in_length < 65536) {
				size_t capacity = h->in_capacity * 2 + 65536;
				unsigned char *in = realloc(h->in, capacity);
				if (!in)
					return broken(h, ENOMEM);
				h->in = in;
				h->in_capacity = capacity;
			}
			/* A blocking call waits for the adapter alone; wake-ups and echoes are
			 * loop_iterate's, which watches the eventfd too. Both wait in poll: a
			 * recv asleep would also be woken, for nothing, each time the adapter
			 * takes a request from the socket (its room to write grows). */
			if (poll(fds, user ? 2 : 1, -1) < 0) {
				if (errno == EINTR)
					continue;
				return broken(h, errno);
			}
			if (user && (fds[1].revents & POLLIN)) {
				uint64_t count;
				if (read(h->event, &count, sizeof count) < 0 && errno != EAGAIN)
					return -1;
				h->signalled = 0;
			}
			if (!(fds[0].revents & (POLLIN | POLLHUP | POLLERR)))
				continue;
			got = recv(h->sock, h->in + h->in_length, h->in_capacity - h->in_length, 0);
			if (got < 0 && (errno == EINTR || errno == EAGAIN))
				continue;
			if (got <= 0)
				return broken(h, got == 0 ? ENODEV : errno);
			h->in_length += got;
		}
	}
}

/* Wait for the reply to ``p`` (other messages are handled meanwhile); 0, or -1 with
 * ``p`` freed when the connection failed. */
static int wait_for(raw1394handle_t h, struct pending *p)
{
	while (!p->done) {
		if (iterate(h, 0) < 0 && h->broken && !p->done) {
			take_pending(h, p->number);
			free(p->data);
			free(p);
			return -1;
		}
	}
	return 0;
}

/* Send ``q`` and wait for its reply; the reply's data in *data (caller frees). */
static int call(raw1394handle_t h, const struct request *q, unsigned char **data, size_t *n,
		raw1394_errcode_t *code)
{
	uint32_t number = put_request(h, q);
	struct pending *p;

	if (!number)
		return -1;
	p = add_pending(h, number, K_WAIT, q->op);
	if (!p)
		return -1;
	if (wait_for(h, p) < 0)
		return -1;
	if (code)
		*code = p->errcode;
	if (data) {
		*data = p->data;
		*n = p->data_length;
	} else {
		free(p->data);
	}
	{
		raw1394_errcode_t e = p->errcode;
		free(p);
		if (e == ERR_REFUSED)
			return fail(EINVAL);
	}
	return 0;
}

/* ---- errors --------------------------------------------------------------------------- */

raw1394_errcode_t raw1394_get_errcode(raw1394handle_t handle)
{
	return handle->err;
}

int raw1394_errcode_to_errno(raw1394_errcode_t errcode)
{
	static const int by_rcode[16] = {
		[RAW1394_RCODE_COMPLETE] = 0,
		[RAW1394_RCODE_CONFLICT_ERROR] = EAGAIN,
		[RAW1394_RCODE_DATA_ERROR] = EREMOTEIO,
		[RAW1394_RCODE_TYPE_ERROR] = EPERM,
		[RAW1394_RCODE_ADDRESS_ERROR] = EINVAL,
	};
	int ack;

	if (raw1394_internal_err(errcode)) {
		switch (errcode) {
		case ERR_GENERATION: case ERR_SEND: case ERR_ABORTED: case ERR_TIMEOUT:
			return EAGAIN;
		default:
			return EINVAL;
		}
	}
	ack = raw1394_get_ack(errcode);
	switch (ack) {
	case ACK_COMPLETE: return 0;
	case ACK_PENDING: {
		int rcode = raw1394_get_rcode(errcode);
		return rcode == 0 || by_rcode[rcode] ? by_rcode[rcode] : EINVAL;
	}
	case 0x4: case 0x5: case 0x6: case 0xB: case 0xC: return EAGAIN;
	case 0xD: return EREMOTEIO;
	case 0xE: return EPERM;
	default: return EINVAL;
	}
}

/* ---- ports ---------------------------------------------------------------------------- */

static const char *runtime_root(char *buffer, size_t size)
{
	const char *base = getenv("XDG_RUNTIME_DIR");

	if (base && *base)
		snprintf(buffer, size, "%s/fw1394", base);
	else
		snprintf(buffer, size, "/tmp/fw1394-%u", (unsigned)getuid());
	return buffer;
}

static int add_port(raw1394handle_t h, const char *name, const char *path)
{
	int i;

	if (h->port_count >= MAX_PORTS || strlen(path) >= sizeof h->ports[0].path)
		return 0;
	for (i = 0; i < h->port_count; i++)
		if (!strcmp(h->ports[i].path, path))
			return 0;
	if (snprintf(h->ports[h->port_count].name, sizeof h->ports[0].name, "%s", name) < 0)
		return 0;
	snprintf(h->ports[h->port_count].path, sizeof h->ports[0].path, "%s", path);
	h->port_count++;
	return 1;
}

static int by_name(const void *a, const void *b)
{
	return strcmp(((const struct port *)a)->name, ((const struct port *)b)->name);
}

/* The buses of this user with an adapter: FW1394_ADAPTER's first, the rest by name. */
static void find_ports(raw1394handle_t h)
{
	const char *chosen = getenv("FW1394_ADAPTER");
	const char *bus = getenv("FW1394_BUS");
	char root[4096], path[4096];
	DIR *dir;
	struct dirent *entry;
	int first;

	h->port_count = 0;
	if (chosen && *chosen)
		add_port(h, bus && *bus ? bus : "fw1394", chosen);
	first = h->port_count;
	dir = opendir(runtime_root(root, sizeof root));
	if (!dir)
		return;
	while ((entry = readdir(dir))) {
		struct stat st;

		if (entry->d_name[0] == '.')
			continue;
		if (snprintf(path, sizeof path, "%s/%s/adapter.sock", root, entry->d_name) >=
		    (int)sizeof path)
			continue;
		if (stat(path, &st) == 0 && S_ISSOCK(st.st_mode))
			add_port(h, entry->d_name, path);
	}
	closedir(dir);
	qsort(h->ports + first, h->port_count - first, sizeof *h->ports, by_name);
}

static int connect_to(const char *path)
{
	struct sockaddr_un address = { .sun_family = AF_UNIX };
	int fd = socket(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0);

	if (fd < 0)
		return -1;
	snprintf(address.sun_path, sizeof address.sun_path, "%s", path);
	if (connect(fd, (struct sockaddr *)&address, sizeof address) < 0) {
		int error = errno;
		close(fd);
		errno = error;
		return -1;
	}
	return fd;
}

/* Agree on the protocol version: the first request of every connection. */
static int hello(raw1394handle_t h)
{
	unsigned char versions[4];
	struct request q = { .op = OP_HELLO, .data = versions, .data_length = sizeof versions };

	put16(versions, PROTOCOL_VERSION);
	put16(versions + 2, PROTOCOL_VERSION);
	if (call(h, &q, NULL, NULL, NULL) < 0) {
		fprintf(stderr, "libraw1394 (fw1394): the bus's adapter does not speak protocol "
				"version %d (EPROTO)\n", PROTOCOL_VERSION);
		return fail(EPROTO);
	}
	return 0;
}

/* Nodes on the bus behind ``path`` (its member table), or -1. */
static int count_nodes(raw1394handle_t h, const char *path)
{
	struct raw1394_handle probe;
	unsigned char *data = NULL;
	size_t n = 0;
	int nodes = -1;
	struct request q = { .op = OP_INFO };

	memset(&probe, 0, sizeof probe);
	probe.sock = connect_to(path);
	probe.event = -1;
	probe.tag_handler = h->tag_handler;
	if (probe.sock < 0)
		return -1;
	if (hello(&probe) == 0 && call(&probe, &q, &data, &n, NULL) == 0 && n >= 8)
		nodes = get16(data + 4);
	free(data);
	free(probe.in);
	close(probe.sock);
	return nodes;
}

int raw1394_get_port_info(raw1394handle_t handle, struct raw1394_portinfo *pinf, int maxports)
{
	int i;

	find_ports(handle);
	for (i = 0; i < maxports && i < handle->port_count; i++) {
		int nodes = count_nodes(handle, handle->ports[i].path);
		pinf[i].nodes = nodes < 0 ? 0 : nodes;
		snprintf(pinf[i].name, sizeof pinf[i].name, "%s", handle->ports[i].name);
	}
	return handle->port_count;
}

static void drop_connection(raw1394handle_t h)
{
	struct pending *p;
	struct arm *arm;

	if (h->sock >= 0) {
		/* Closing with replies unread would make the adapter lose the requests it has
		 * not read yet: say we are done, and read until it has seen that (at most 2 s). */
		struct pollfd pfd = { h->sock, POLLIN, 0 };
		unsigned char sink[4096];

		shutdown(h->sock, SHUT_WR);
		while (poll(&pfd, 1, 2000) > 0 && recv(h->sock, sink, sizeof sink, 0) > 0)
			;
		epoll_ctl(h->epoll, EPOLL_CTL_DEL, h->sock, NULL);
		close(h->sock);
	}
	h->sock = -1;
	while ((p = h->pending)) {
		h->pending = p->next;
		free(p->data);
		free(p);
	}
	while ((arm = h->arms)) {
		h->arms = arm->next;
		free(arm->memory);
		free(arm);
	}
	h->in_length = 0;
	h->watch = h->fcp = 0;
	/* Isochronous state belongs to the connection too. */
	free(h->iso.packet);
	memset(&h->iso, 0, sizeof h->iso);
}

int raw1394_set_port(raw1394handle_t handle, int port)
{
	struct epoll_event event = { .events = EPOLLIN };
	struct request q = { .op = OP_WATCH };
	uint32_t number;
	struct pending *p;

	if (!handle->port_count)
		find_ports(handle);
	if (port < 0 || port >= handle->port_count)
		return fail(ENOENT);
	drop_connection(handle);
	handle->broken = 0;
	handle->sock = connect_to(handle->ports[port].path);
	if (handle->sock < 0)
		return fail(ESTALE);
	event.data.fd = handle->sock;
	if (epoll_ctl(handle->epoll, EPOLL_CTL_ADD, handle->sock, &event) < 0)
		return -1;
	if (hello(handle) < 0)
		return -1;
	/* The first bus state is the watch request's reply; later ones are pushes. */
	number = put_request(handle, &q);
	if (!number)
		return -1;
	p = add_pending(handle, number, K_WAIT, OP_WATCH);
	if (!p || wait_for(handle, p) < 0)
		return -1;
	if (p->data_length >= 2) {
		handle->nodes = p->data[0];
		handle->irm = p->data[1];
	}
	handle->generation = p->generation;
	handle->phy = p->phy;
	free(p->data);
	free(p);
	handle->watch = number;
	/* dumpiso and sendiso read errno after a successful set_port. */
	errno = 0;
	return 0;
}

/* ---- handles -------------------------------------------------------------------------- */

static int default_tag_handler(raw1394handle_t h, unsigned long tag, raw1394_errcode_t err)
{
	struct raw1394_reqhandle *rh = (struct raw1394_reqhandle *)tag;

	if (rh && rh->callback)
		return rh->callback(h, rh->data, err);
	return 0;
}

static int default_arm_tag_handler(raw1394handle_t h, unsigned long tag, byte_t type,
				   unsigned int length, void *data)
{
	struct raw1394_arm_reqhandle *rh = (struct raw1394_arm_reqhandle *)tag;

	if (rh && rh->arm_callback)
		return rh->arm_callback(h, data, length, rh->pcontext, type);
	return 0;
}

static int default_reset_handler(raw1394handle_t h, unsigned int generation)
{
	raw1394_update_generation(h, generation);
	return 0;
}

raw1394handle_t raw1394_new_handle(void)
{
	raw1394handle_t h = calloc(1, sizeof *h);
	struct epoll_event event = { .events = EPOLLIN };

	if (!h)
		return NULL;
	h->sock = -1;
	h->epoll = epoll_create1(EPOLL_CLOEXEC);
	h->event = eventfd(0, EFD_CLOEXEC | EFD_NONBLOCK);
	if (h->epoll < 0 || h->event < 0) {
		int error = errno;
		if (h->epoll >= 0)
			close(h->epoll);
		if (h->event >= 0)
			close(h->event);
		free(h);
		errno = error;
		return NULL;
	}
	event.data.fd = h->event;
	epoll_ctl(h->epoll, EPOLL_CTL_ADD, h->event, &event);
	h->notify = RAW1394_NOTIFY_ON;
	h->tag_handler = default_tag_handler;
	h->arm_tag_handler = default_arm_tag_handler;
	h->reset_handler = default_reset_handler;
	h->phy = 63;
	return h;
}

raw1394handle_t raw1394_new_handle_on_port(int port)
{
	raw1394handle_t h = raw1394_new_handle();

	if (!h)
		return NULL;
	find_ports(h);
	if (raw1394_set_port(h, port) < 0) {
		int error = errno;
		raw1394_destroy_handle(h);
		errno = error;
		return NULL;
	}
	raw1394_update_generation(h, raw1394_get_generation(h));
	return h;
}

void raw1394_destroy_handle(raw1394handle_t handle)
{
	if (!handle)
		return;
	if (handle->sock >= 0)
		raw1394_iso_shutdown(handle);
	drop_connection(handle);
	close(handle->epoll);
	close(handle->event);
	free(handle->in);
	free(handle->echoes);
	free(handle);
}

int raw1394_busreset_notify(raw1394handle_t handle, int off_on_switch)
{
	handle->notify = off_on_switch;
	return 0;
}

int raw1394_get_fd(raw1394handle_t handle) { return handle->epoll; }
void raw1394_set_userdata(raw1394handle_t handle, void *data) { handle->userdata = data; }
void *raw1394_get_userdata(raw1394handle_t handle) { return handle->userdata; }
nodeid_t raw1394_get_local_id(raw1394handle_t handle) { return 0xFFC0 | (handle->phy & 0x3F); }
nodeid_t raw1394_get_irm_id(raw1394handle_t handle) { return 0xFFC0 | (handle->irm & 0x3F); }
int raw1394_get_nodecount(raw1394handle_t handle) { return handle->nodes; }
unsigned int raw1394_get_generation(raw1394handle_t handle) { return handle->generation; }
const char *raw1394_get_libversion(void) { return LIBVERSION; }

void raw1394_update_generation(raw1394handle_t handle, unsigned int generation)
{
	handle->generation = generation;
}

int raw1394_get_speed(raw1394handle_t handle, nodeid_t node)
{
	/* Every member of the virtual bus reports S400 in its self-ID packet. */
	if ((node & 0x3F) >= handle->nodes)
		return fail(EINVAL);
	return RAW1394_ISO_SPEED_400;
}

bus_reset_handler_t raw1394_set_bus_reset_handler(raw1394handle_t handle, bus_reset_handler_t new_h)
{
	bus_reset_handler_t old = handle->reset_handler;
	handle->reset_handler = new_h;
	return old;
}

tag_handler_t raw1394_set_tag_handler(raw1394handle_t handle, tag_handler_t new_h)
{
	tag_handler_t old = handle->tag_handler;
	handle->tag_handler = new_h;
	return old;
}

arm_tag_handler_t raw1394_set_arm_tag_handler(raw1394handle_t handle, arm_tag_handler_t new_h)
{
	arm_tag_handler_t old = handle->arm_tag_handler;
	handle->arm_tag_handler = new_h;
	return old;
}

fcp_handler_t raw1394_set_fcp_handler(raw1394handle_t handle, fcp_handler_t new_h)
{
	fcp_handler_t old = handle->fcp_handler;
	handle->fcp_handler = new_h;
	return old;
}

int raw1394_loop_iterate(raw1394handle_t handle)
{
	return iterate(handle, 1);
}

int raw1394_wake_up(raw1394handle_t handle)
{
	uint64_t one = 1;

	handle->woken = 1;
	if (write(handle->event, &one, sizeof one) < 0)
		return -1;
	handle->signalled = 1;
	return 0;
}

int raw1394_echo_request(raw1394handle_t handle, quadlet_t data)
{
	quadlet_t *echoes = realloc(handle->echoes, (handle->echo_count + 1) * sizeof data);
	uint64_t one = 1;

	if (!echoes)
		return -1;
	handle->echoes = echoes;
	echoes[handle->echo_count++] = data;
	if (write(handle->event, &one, sizeof one) < 0)
		return -1;
	handle->signalled = 1;
	return 0;
}

int raw1394_reset_bus_new(raw1394handle_t handle, int type)
{
	struct request q = { .op = OP_RESET };

	/* Long and short resets are one kind on the virtual bus. */
	(void)type;
	return call(handle, &q, NULL, NULL, NULL);
}

int raw1394_reset_bus(raw1394handle_t handle)
{
	return raw1394_reset_bus_new(handle, RAW1394_LONG_RESET);
}

/* ---- transactions --------------------------------------------------------------------- */

static int start(raw1394handle_t h, struct request *q, enum kind kind, void *result, size_t length,
		 unsigned long tag, struct pending **out)
{
	uint32_t number;
	struct pending *p;

	q->node &= 0x3F;
	q->generation = h->generation;
	number = put_request(h, q);
	if (!number)
		return -1;
	p = add_pending(h, number, kind, q->op);
	if (!p)
		return -1;
	p->tag = tag;
	p->result = result;
	p->length = length;
	if (out)
		*out = p;
	return 0;
}

static int finish(raw1394handle_t h, struct request *q, void *result, size_t length)
{
	struct pending *p;
	raw1394_errcode_t code;
	int error;

	if (start(h, q, K_WAIT, result, length, 0, &p) < 0)
		return -1;
	if (wait_for(h, p) < 0)
		return -1;
	code = p->errcode;
	free(p->data);
	free(p);
	h->err = code;
	error = raw1394_errcode_to_errno(code);
	return error ? fail(error) : 0;
}

static void read_request(struct request *q, nodeid_t node, nodeaddr_t addr, size_t length)
{
	memset(q, 0, sizeof *q);
	q->op = OP_READ;
	q->node = node;
	q->offset = addr;
	q->length = length;
	q->quadlet = length == 4;
}

static void write_request(struct request *q, nodeid_t node, nodeaddr_t addr, size_t length,
			  const void *data)
{
	memset(q, 0, sizeof *q);
	q->op = OP_WRITE;
	q->node = node;
	q->offset = addr;
	q->length = length;
	q->quadlet = length == 4;
	q->data = data;
	q->data_length = length;
}

/* A lock's argument and data as the adapter takes them (bus byte order, as given). */
static void lock_request(struct request *q, nodeid_t node, nodeaddr_t addr, unsigned int extcode,
			 const void *data, const void *arg, size_t size)
{
	int one = extcode == RAW1394_EXTCODE_FETCH_ADD || extcode == RAW1394_EXTCODE_LITTLE_ADD;

	memset(q, 0, sizeof *q);
	q->op = OP_LOCK;
	q->node = node;
	q->offset = addr;
	q->extended_tcode = extcode;
	q->argument = one ? NULL : arg;
	q->argument_length = one ? 0 : size;
	q->data = data;
	q->data_length = size;
}

int raw1394_start_read(raw1394handle_t handle, nodeid_t node, nodeaddr_t addr, size_t length,
		       quadlet_t *buffer, unsigned long tag)
{
	struct request q;

	read_request(&q, node, addr, length);
	return start(handle, &q, K_TAG, buffer, length, tag, NULL);
}

int raw1394_start_write(raw1394handle_t handle, nodeid_t node, nodeaddr_t addr, size_t length,
			quadlet_t *data, unsigned long tag)
{
	struct request q;

	write_request(&q, node, addr, length, data);
	return start(handle, &q, K_TAG, NULL, 0, tag, NULL);
}

int raw1394_start_lock(raw1394handle_t handle, nodeid_t node, nodeaddr_t addr,
		       unsigned int extcode, quadlet_t data, quadlet_t arg, quadlet_t *result,
		       unsigned long tag)
{
	struct request q;

	lock_request(&q, node, addr, extcode, &data, &arg, 4);
	return start(handle, &q, K_TAG, result, 4, tag, NULL);
}

int raw1394_start_lock64(raw1394handle_t handle, nodeid_t node, nodeaddr_t addr,
			 unsigned int extcode, octlet_t data, octlet_t arg, octlet_t *result,
			 unsigned long tag)
{
	struct request q;

	lock_request(&q, node, addr, extcode, &data, &arg, 8);
	return start(handle, &q, K_TAG, result, 8, tag, NULL);
}

int raw1394_read(raw1394handle_t handle, nodeid_t node, nodeaddr_t addr, size_t length,
		 quadlet_t *buffer)
{
	struct request q;

	read_request(&q, node, addr, length);
	return finish(handle, &q, buffer, length);
}

int raw1394_write(raw1394handle_t handle, nodeid_t node, nodeaddr_t addr, size_t length,
		  quadlet_t *data)
{
	struct request q;

	write_request(&q, node, addr, length, data);
	return finish(handle, &q, NULL, 0);
}

int raw1394_lock(raw1394handle_t handle, nodeid_t node, nodeaddr_t addr, unsigned int extcode,
		 quadlet_t data, quadlet_t arg, quadlet_t *result)
{
	struct request q;

	lock_request(&q, node, addr, extcode, &data, &arg, 4);
	return finish(handle, &q, result, 4);
}

int raw1394_lock64(raw1394handle_t handle, nodeid_t node, nodeaddr_t addr, unsigned int extcode,
		   octlet_t data, octlet_t arg, octlet_t *result)
{
	struct request q;

	lock_request(&q, node, addr, extcode, &data, &arg, 8);
	return finish(handle, &q, result, 8);
}

/* ---- the local node ------------------------------------------------------------------- */

int raw1394_arm_register(raw1394handle_t handle, nodeaddr_t start, size_t length,
			 byte_t *initial_value, octlet_t arm_tag, arm_options_t access_rights,
			 arm_options_t notification_options, arm_options_t client_transactions)
{
	struct request q = { .op = OP_LISTEN, .offset = start, .length = length };
	struct arm *arm;
	uint32_t number;
	struct pending *p;
	raw1394_errcode_t code;

	/* Requests the library does not answer from memory are answered with a type
	 * error; there is no call to answer them from the program (as on juju). */
	(void)client_transactions;
	arm = calloc(1, sizeof *arm);
	if (!arm || !(arm->memory = calloc(1, length ? length : 1))) {
		free(arm);
		return fail(ENOMEM);
	}
	if (initial_value)
		memcpy(arm->memory, initial_value, length);
	arm->start = start;
	arm->length = length;
	arm->tag = arm_tag;
	arm->access = access_rights;
	arm->notify = notification_options;
	number = put_request(handle, &q);
	p = number ? add_pending(handle, number, K_WAIT, OP_LISTEN) : NULL;
	if (!p || wait_for(handle, p) < 0) {
		free(arm->memory);
		free(arm);
		return -1;
	}
	code = p->errcode;
	free(p->data);
	free(p);
	if (code == ERR_REFUSED) {
		free(arm->memory);
		free(arm);
		return fail(EADDRINUSE);
	}
	arm->number = number;
	arm->next = handle->arms;
	handle->arms = arm;
	return 0;
}

int raw1394_arm_unregister(raw1394handle_t handle, nodeaddr_t start)
{
	struct request q = { .op = OP_UNLISTEN, .offset = start };
	struct arm **at;

	for (at = &handle->arms; *at; at = &(*at)->next) {
		if ((*at)->start == start) {
			struct arm *arm = *at;
			*at = arm->next;
			free(arm->memory);
			free(arm);
			return call(handle, &q, NULL, NULL, NULL);
		}
	}
	return fail(EINVAL);
}

int raw1394_arm_set_buf(raw1394handle_t handle, nodeaddr_t start, size_t length, void *buf)
{
	struct arm *arm;

	for (arm = handle->arms; arm; arm = arm->next)
		if (arm->start <= start && start + length <= arm->start + arm->length) {
			memcpy(arm->memory + (start - arm->start), buf, length);
			return 0;
		}
	return fail(EINVAL);
}

int raw1394_arm_get_buf(raw1394handle_t handle, nodeaddr_t start, size_t length, void *buf)
{
	struct arm *arm;

	for (arm = handle->arms; arm; arm = arm->next)
		if (arm->start <= start && start + length <= arm->start + arm->length) {
			memcpy(buf, arm->memory + (start - arm->start), length);
			return 0;
		}
	return fail(EINVAL);
}

int raw1394_start_fcp_listen(raw1394handle_t handle)
{
	struct request q = { .op = OP_LISTEN, .offset = CSR_REGISTER_BASE + CSR_FCP_COMMAND,
			     .length = CSR_FCP_END - CSR_FCP_COMMAND, .extended_tcode = 1 };
	uint32_t number;
	struct pending *p;
	raw1394_errcode_t code;

	if (handle->fcp)
		return 0;
	number = put_request(handle, &q);
	p = number ? add_pending(handle, number, K_WAIT, OP_LISTEN) : NULL;
	if (!p || wait_for(handle, p) < 0)
		return -1;
	code = p->errcode;
	free(p->data);
	free(p);
	if (code == ERR_REFUSED)
		return fail(EINVAL);
	handle->fcp = number;
	return 0;
}

int raw1394_stop_fcp_listen(raw1394handle_t handle)
{
	struct request q = { .op = OP_UNLISTEN, .offset = CSR_REGISTER_BASE + CSR_FCP_COMMAND };

	if (!handle->fcp)
		return fail(EINVAL);
	handle->fcp = 0;
	return call(handle, &q, NULL, NULL, NULL);
}

int raw1394_get_config_rom(raw1394handle_t handle, quadlet_t *buffer, size_t buffersize,
			   size_t *rom_size, unsigned char *rom_version)
{
	struct request q = { .op = OP_CONFIG_ROM };
	unsigned char *data = NULL;
	size_t n = 0;

	if (call(handle, &q, &data, &n, NULL) < 0)
		return -1;
	if (n < 1) {
		free(data);
		return fail(EPROTO);
	}
	*rom_version = data[0];
	*rom_size = n - 1;
	memcpy(buffer, data + 1, n - 1 < buffersize ? n - 1 : buffersize);
	free(data);
	return 0;
}

int raw1394_update_config_rom(raw1394handle_t handle, const quadlet_t *new_rom, size_t size,
			      unsigned char rom_version)
{
	struct request q = { .op = OP_CONFIG_ROM, .length = rom_version, .data = new_rom,
			     .data_length = size };
	raw1394_errcode_t code;

	if (size > 1024)
		return -2;
	if (call(handle, &q, NULL, NULL, &code) < 0)
		return -1;
	return 0;
}

static int cycle_time(raw1394handle_t h, u_int32_t *cycle_timer, u_int64_t *local_time,
		      clockid_t clock)
{
	struct request q = { .op = OP_CYCLE_TIME };
	unsigned char *data = NULL;
	size_t n = 0;
	struct timespec before, after;

	clock_gettime(clock, &before);
	if (call(h, &q, &data, &n, NULL) < 0)
		return -1;
	clock_gettime(clock, &after);
	if (n < 4) {
		free(data);
		return fail(EPROTO);
	}
	*cycle_timer = get32(data);
	free(data);
	/* The register was sampled between the two readings: take their middle. */
	*local_time = ((u_int64_t)before.tv_sec * 1000000 + before.tv_nsec / 1000 +
		       (u_int64_t)after.tv_sec * 1000000 + after.tv_nsec / 1000) / 2;
	return 0;
}

int raw1394_read_cycle_timer(raw1394handle_t handle, u_int32_t *cycle_timer, u_int64_t *local_time)
{
	return cycle_time(handle, cycle_timer, local_time, CLOCK_REALTIME);
}

int raw1394_read_cycle_timer_and_clock(raw1394handle_t handle, u_int32_t *cycle_timer,
				       u_int64_t *local_time, clockid_t clk_id)
{
	return cycle_time(handle, cycle_timer, local_time, clk_id);
}

/* ---- what the virtual bus does not carry ----------------------------------------------- */

static int said_raw, said_resources;

static int no_raw(void)
{
	say_once(&said_raw, "raw packets and PHY packets are not supported (ENOSYS)");
	return fail(ENOSYS);
}

int raw1394_add_config_rom_descriptor(raw1394handle_t handle, u_int32_t *token,
				      quadlet_t immediate_key, quadlet_t key,
				      const quadlet_t *data, size_t size)
{
	struct request q = { .op = OP_ADD_DESCRIPTOR, .offset = immediate_key, .length = key,
			     .data_length = size };
	unsigned char *reply = NULL, *bus = malloc(size ? size : 1);
	size_t n = 0, i;
	int result;

	/* Unlike transaction buffers, descriptor quadlets are in host byte order. */
	if (!bus)
		return fail(ENOMEM);
	for (i = 0; i < size / 4; i++)
		put32(bus + 4 * i, data[i]);
	q.data = bus;
	result = call(handle, &q, &reply, &n, NULL);
	free(bus);
	if (result < 0)
		return -1;
	if (n >= 4 && token)
		*token = get32(reply);
	free(reply);
	return n >= 4 ? 0 : fail(EPROTO);
}

int raw1394_remove_config_rom_descriptor(raw1394handle_t handle, u_int32_t token)
{
	struct request q = { .op = OP_REMOVE_DESCRIPTOR, .offset = token };

	return call(handle, &q, NULL, NULL, NULL);
}

int raw1394_bandwidth_modify(raw1394handle_t handle, unsigned int bandwidth,
			     enum raw1394_modify_mode mode)
{
	(void)handle; (void)bandwidth; (void)mode;
	say_once(&said_resources, "isochronous resources are not allocated on the virtual bus "
				  "(ENOSYS)");
	return fail(ENOSYS);
}

int raw1394_channel_modify(raw1394handle_t handle, unsigned int channel,
			   enum raw1394_modify_mode mode)
{
	(void)handle; (void)channel; (void)mode;
	say_once(&said_resources, "isochronous resources are not allocated on the virtual bus "
				  "(ENOSYS)");
	return fail(ENOSYS);
}

int raw1394_phy_packet_write(raw1394handle_t handle, quadlet_t data)
{
	(void)handle; (void)data;
	return no_raw();
}

int raw1394_start_phy_packet_write(raw1394handle_t handle, quadlet_t data, unsigned long tag)
{
	(void)handle; (void)data; (void)tag;
	return no_raw();
}

/* An asynchronous stream packet: a stream packet on a channel, outside the cycle
 * schedule; whoever listens to the channel receives it. */
int raw1394_start_async_stream(raw1394handle_t handle, unsigned int channel, unsigned int tag,
			       unsigned int sy, unsigned int speed, size_t length, quadlet_t *data,
			       unsigned long rawtag)
{
	struct request q = { .op = OP_ISO_SEND, .node = channel,
			     .extended_tcode = (tag & 3) << 4 | (sy & 0xF), .data = data,
			     .data_length = length };
	uint32_t number;
	struct pending *p;

	(void)speed;
	if (channel > 63)
		return fail(EINVAL);
	number = put_request(handle, &q);
	if (!number || !(p = add_pending(handle, number, K_TAG, OP_ISO_SEND)))
		return -1;
	p->tag = rawtag;
	return 0;
}

int raw1394_start_async_send(raw1394handle_t handle, size_t length, size_t header_length,
			     unsigned int expect_response, quadlet_t *data, unsigned long rawtag)
{
	(void)handle; (void)length; (void)header_length; (void)expect_response; (void)data;
	(void)rawtag;
	return no_raw();
}

int raw1394_async_stream(raw1394handle_t handle, unsigned int channel, unsigned int tag,
			 unsigned int sy, unsigned int speed, size_t length, quadlet_t *data)
{
	struct request q = { .op = OP_ISO_SEND, .node = channel,
			     .extended_tcode = (tag & 3) << 4 | (sy & 0xF), .data = data,
			     .data_length = length };
	raw1394_errcode_t code;

	(void)speed;
	if (channel > 63)
		return fail(EINVAL);
	if (call(handle, &q, NULL, NULL, &code) < 0)
		return -1;
	handle->err = code;
	return 0;
}

int raw1394_async_send(raw1394handle_t handle, size_t length, size_t header_length,
		       unsigned int expect_response, quadlet_t *data)
{
	return raw1394_start_async_send(handle, length, header_length, expect_response, data, 0);
}

/* Wait for the next cycle: a channel carries one packet per cycle. */
static void iso_pace(raw1394handle_t h)
{
	struct timespec now;

	clock_gettime(CLOCK_MONOTONIC, &now);
	if (now.tv_sec < h->iso.next.tv_sec ||
	    (now.tv_sec == h->iso.next.tv_sec && now.tv_nsec < h->iso.next.tv_nsec))
		clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &h->iso.next, NULL);
	else
		h->iso.next = now;
	h->iso.next.tv_nsec += CYCLE_NS;
	if (h->iso.next.tv_nsec >= 1000000000L) {
		h->iso.next.tv_nsec -= 1000000000L;
		h->iso.next.tv_sec++;
	}
}

/* Take what the adapter sent without waiting or handling it (a transmitting program
 * may never call loop_iterate; the adapter must not wait on a full socket). */
static void take_waiting(raw1394handle_t h)
{
	for (;;) {
		ssize_t got;

		if (h->in_capacity - h->in_length < 65536) {
			size_t capacity = h->in_capacity * 2 + 65536;
			unsigned char *in = realloc(h->in, capacity);
			if (!in)
				return;
			h->in = in;
			h->in_capacity = capacity;
		}
		got = recv(h->sock, h->in + h->in_length, h->in_capacity - h->in_length,
			   MSG_DONTWAIT);
		if (got <= 0)
			break;
		h->in_length += got;
	}
	signal_pending(h);
}

static int iso_send(raw1394handle_t h, const unsigned char *data, unsigned int len,
		    unsigned char tag, unsigned char sy)
{
	struct request q = { .op = OP_ISO_SEND, .node = h->iso.channel,
			     .extended_tcode = (tag & 3) << 4 | (sy & 0xF), .data = data,
			     .data_length = len };

	iso_pace(h);
	/* The adapter's confirmation is not waited for: nobody is owed it. */
	if (!put_request(h, &q))
		return -1;
	take_waiting(h);
	return 0;
}

static int iso_pump(raw1394handle_t h)
{
	unsigned int len = 0;
	unsigned char tag = 0, sy = 0;
	enum raw1394_iso_disposition disposition;

	disposition = h->iso.xmit(h, h->iso.packet, &len, &tag, &sy, -1, 0);
	switch (disposition) {
	case RAW1394_ISO_OK:
	case RAW1394_ISO_DEFER:
		if (len > h->iso.max_packet)
			return fail(EINVAL);
		return iso_send(h, h->iso.packet, len, tag, sy);
	case RAW1394_ISO_AGAIN:
		return 0;
	case RAW1394_ISO_STOP:
	case RAW1394_ISO_STOP_NOSYNC:
		h->iso.started = 0;
		signal_pending(h);
		return 0;
	default:
		return -1;
	}
}

static int iso_listen(raw1394handle_t h, uint64_t mask)
{
	struct request q = { .op = OP_ISO_LISTEN, .offset = mask };
	uint32_t number = put_request(h, &q);
	struct pending *p;

	if (!number)
		return -1;
	p = add_pending(h, number, K_WAIT, OP_ISO_LISTEN);
	if (!p || wait_for(h, p) < 0)
		return -1;
	free(p->data);
	free(p);
	h->iso.listen = mask ? number : 0;
	return 0;
}

static void iso_stop_receiving(raw1394handle_t h)
{
	struct request q = { .op = OP_ISO_LISTEN };

	if (h->iso.mode == ISO_RECV && h->iso.started && h->sock >= 0)
		put_request(h, &q); /* its confirmation is not waited for */
	h->iso.listen = 0;
	h->iso.started = 0;
}

static int iso_init(raw1394handle_t h, enum iso_mode mode, unsigned int max_packet)
{
	if (h->sock < 0)
		return fail(ENOTCONN);
	if (h->iso.mode != ISO_OFF)
		return fail(EBUSY);
	memset(&h->iso, 0, sizeof h->iso);
	h->iso.mode = mode;
	h->iso.max_packet = max_packet;
	return 0;
}

int raw1394_iso_xmit_init(raw1394handle_t handle, raw1394_iso_xmit_handler_t handler,
			  unsigned int buf_packets, unsigned int max_packet_size,
			  unsigned char channel, enum raw1394_iso_speed speed, int irq_interval)
{
	(void)buf_packets; (void)speed; (void)irq_interval;
	if (channel > 63)
		return fail(EINVAL);
	if (iso_init(handle, ISO_XMIT, max_packet_size) < 0)
		return -1;
	handle->iso.xmit = handler;
	handle->iso.channel = channel;
	if (handler && !(handle->iso.packet = malloc(max_packet_size ? max_packet_size : 1))) {
		handle->iso.mode = ISO_OFF;
		return fail(ENOMEM);
	}
	return 0;
}

int raw1394_iso_recv_init(raw1394handle_t handle, raw1394_iso_recv_handler_t handler,
			  unsigned int buf_packets, unsigned int max_packet_size,
			  unsigned char channel, enum raw1394_iso_dma_recv_mode mode,
			  int irq_interval)
{
	(void)buf_packets; (void)mode; (void)irq_interval;
	if (channel > 63)
		return fail(EINVAL);
	if (iso_init(handle, ISO_RECV, max_packet_size) < 0)
		return -1;
	handle->iso.recv = handler;
	handle->iso.mask = 1ULL << channel;
	return 0;
}

int raw1394_iso_multichannel_recv_init(raw1394handle_t handle, raw1394_iso_recv_handler_t handler,
				       unsigned int buf_packets, unsigned int max_packet_size,
				       int irq_interval)
{
	(void)buf_packets; (void)irq_interval;
	if (iso_init(handle, ISO_RECV, max_packet_size) < 0)
		return -1;
	handle->iso.recv = handler;
	return 0;
}

static int iso_set_mask(raw1394handle_t h, uint64_t mask)
{
	if (h->iso.mode != ISO_RECV)
		return fail(EINVAL);
	h->iso.mask = mask;
	return h->iso.started ? iso_listen(h, mask) : 0;
}

int raw1394_iso_recv_listen_channel(raw1394handle_t handle, unsigned char channel)
{
	if (channel > 63)
		return fail(EINVAL);
	return iso_set_mask(handle, handle->iso.mask | 1ULL << channel);
}

int raw1394_iso_recv_unlisten_channel(raw1394handle_t handle, unsigned char channel)
{
	if (channel > 63)
		return fail(EINVAL);
	return iso_set_mask(handle, handle->iso.mask & ~(1ULL << channel));
}

int raw1394_iso_recv_set_channel_mask(raw1394handle_t handle, u_int64_t mask)
{
	return iso_set_mask(handle, mask);
}

int raw1394_iso_xmit_start(raw1394handle_t handle, int start_on_cycle, int prebuffer_packets)
{
	(void)start_on_cycle; (void)prebuffer_packets;
	if (handle->iso.mode != ISO_XMIT)
		return fail(EINVAL);
	handle->iso.started = 1;
	clock_gettime(CLOCK_MONOTONIC, &handle->iso.next);
	signal_pending(handle);
	return 0;
}

int raw1394_iso_recv_start(raw1394handle_t handle, int start_on_cycle, int tag_mask, int sync)
{
	(void)start_on_cycle; (void)tag_mask; (void)sync;
	if (handle->iso.mode != ISO_RECV)
		return fail(EINVAL);
	if (iso_listen(handle, handle->iso.mask) < 0)
		return -1;
	handle->iso.started = 1;
	return 0;
}

int raw1394_iso_xmit_write(raw1394handle_t handle, unsigned char *data, unsigned int len,
			   unsigned char tag, unsigned char sy)
{
	if (handle->iso.mode != ISO_XMIT || handle->iso.xmit)
		return fail(EINVAL);
	if (len > handle->iso.max_packet)
		return fail(EINVAL);
	if (!handle->iso.started)
		raw1394_iso_xmit_start(handle, -1, -1);
	return iso_send(handle, data, len, tag, sy);
}

int raw1394_iso_xmit_sync(raw1394handle_t handle)
{
	struct request q = { .op = OP_CYCLE_TIME };

	if (handle->iso.mode != ISO_XMIT)
		return fail(EINVAL);
	/* The adapter answers in order: once this is answered, every packet went out. */
	return call(handle, &q, NULL, NULL, NULL);
}

int raw1394_iso_recv_flush(raw1394handle_t handle)
{
	return handle->iso.mode == ISO_RECV ? 0 : fail(EINVAL);
}

void raw1394_iso_stop(raw1394handle_t handle)
{
	if (handle->iso.mode == ISO_RECV)
		iso_stop_receiving(handle);
	handle->iso.started = 0;
	signal_pending(handle);
}

void raw1394_iso_shutdown(raw1394handle_t handle)
{
	raw1394_iso_stop(handle);
	free(handle->iso.packet);
	memset(&handle->iso, 0, sizeof handle->iso);
}
