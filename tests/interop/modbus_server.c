/*
 * A small Modbus TCP instrument built on libmodbus -- an implementation independent of pymodbus -- for
 * the interoperability tests of the `modbus` driver (tests/test_interop.py).
 *
 *   modbus_server TYPE ORDER SCALE
 *
 * listens on 127.0.0.1 (a free port, printed as "PORT <n>"), holds the heater set-point in holding
 * registers 0.. and the PSD voltage in input registers 0.., both encoded as TYPE (float32 | int32 | int16)
 * times SCALE, 32-bit values in ORDER (big: ABCD, little: CDAB) -- decoded with libmodbus's own float
 * getters (its 3.1.6 setters are wrong, see encode()).
 * After every request that writes the set-point it prints "SET <volts>" and sets the PSD to
 * 0.25 * volts - 1 (V), so a client can check both directions.  It serves one client at a time and
 * accepts the next when one disconnects; it exits on end of input on stdin (the test closing the pipe).
 */
#include <errno.h>
#include <math.h>
#include <modbus.h>
#include <netinet/in.h>
#include <poll.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/socket.h>
#include <unistd.h>

static const char *type, *order;
static double scale;

static double decode(const uint16_t *r) {
    int big = strcmp(order, "big") == 0;
    if (strcmp(type, "float32") == 0)
        return (big ? modbus_get_float_abcd(r) : modbus_get_float_cdab(r)) / scale;
    if (strcmp(type, "int32") == 0) {
        uint32_t u = big ? ((uint32_t)r[0] << 16) | r[1] : ((uint32_t)r[1] << 16) | r[0];
        return (double)(int32_t)u / scale;
    }
    return (double)(int16_t)r[0] / scale;
}

static void encode(double volts, uint16_t *r) {
    int big = strcmp(order, "big") == 0;
    if (strcmp(type, "float32") == 0 || strcmp(type, "int32") == 0) {
        /* not modbus_set_float_abcd/_cdab: in libmodbus 3.1.6 they put the bytes of each word in the wrong
           order (libmodbus issue #611, fixed in 3.1.7); the getters used in decode() are right */
        uint32_t u;
        if (strcmp(type, "float32") == 0) {
            float f = (float)(volts * scale);
            memcpy(&u, &f, sizeof u);
        } else {
            u = (uint32_t)(int32_t)lround(volts * scale);
        }
        r[big ? 0 : 1] = (uint16_t)(u >> 16);
        r[big ? 1 : 0] = (uint16_t)(u & 0xFFFF);
    } else {
        r[0] = (uint16_t)(int16_t)lround(volts * scale);
    }
}

int main(int argc, char **argv) {
    if (argc != 4) { fprintf(stderr, "usage: %s float32|int32|int16 big|little SCALE\n", argv[0]); return 2; }
    type = argv[1]; order = argv[2]; scale = atof(argv[3]);
    modbus_t *ctx = modbus_new_tcp("127.0.0.1", 0);
    modbus_mapping_t *map = modbus_mapping_new(0, 0, 16, 16);
    if (!ctx || !map) { fprintf(stderr, "libmodbus: %s\n", modbus_strerror(errno)); return 1; }
    int server = modbus_tcp_listen(ctx, 1);
    if (server < 0) { fprintf(stderr, "listen: %s\n", modbus_strerror(errno)); return 1; }
    struct sockaddr_in where; socklen_t len = sizeof where;
    getsockname(server, (struct sockaddr *)&where, &len);
    printf("PORT %d\n", ntohs(where.sin_port)); fflush(stdout);
    encode(-1.0, map->tab_input_registers);
    uint8_t query[MODBUS_TCP_MAX_ADU_LENGTH];
    for (;;) {
        struct pollfd fds[2] = {{server, POLLIN, 0}, {0, POLLIN, 0}};
        if (poll(fds, 2, -1) < 0) continue;
        if (fds[1].revents) { char c; if (read(0, &c, 1) <= 0) break; }  /* stdin closed: stop */
        if (!(fds[0].revents & POLLIN)) continue;
        int client = modbus_tcp_accept(ctx, &server);  /* the new connection (the listening socket stays) */
        if (client < 0) continue;
        for (;;) {
            int rc = modbus_receive(ctx, query);
            if (rc == 0) continue;  /* a request for another unit: ignored */
            if (rc < 0) break;      /* the client closed the connection */
            modbus_reply(ctx, query, rc, map);
            int function = query[modbus_get_header_length(ctx)];
            if (function == MODBUS_FC_WRITE_MULTIPLE_REGISTERS || function == MODBUS_FC_WRITE_SINGLE_REGISTER) {
                double volts = decode(map->tab_registers);
                printf("SET %.9g\n", volts); fflush(stdout);
                encode(0.25 * volts - 1.0, map->tab_input_registers);
            }
        }
        close(client);
    }
    modbus_mapping_free(map); modbus_free(ctx);
    return 0;
}
