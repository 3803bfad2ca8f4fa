/* The contract between a device program (tiny/apps/NAME.c) and a port
 * (tiny/ports/<name>/). A device program is written against tiny_kernel.h
 * and this header only, so the same source builds for every port: the port
 * owns main(), the radio HAL, the clock and the board's sensors and
 * actuators; the program owns the behaviour.
 *
 * Values on the radio: the device programs carry numbers as ASCII decimal
 * text (the plant's "blind close" is the one byte "0"), the same bytes a
 * full PEIS shows for the tuple, so the bridge copies data unchanged.
 */
#ifndef TINY_APP_H
#define TINY_APP_H

#include "tiny_kernel.h"

#ifdef __cplusplus
extern "C" {
#endif

/* Key indexes of the seed's registry (tiny-peis-kernel.txt section V). */
#define TINY_KEY_LIGHT_VALUE 42    /* LightValue */
#define TINY_KEY_TILT_VALUE 43     /* TiltValue */
#define TINY_KEY_WEIGHT 44         /* Weight (the parcel) */
#define TINY_KEY_LAMP_LEVEL 45     /* LampLevel: the level the lamp has set */
#define TINY_KEY_BLIND_POSITION 46 /* BlindPosition: 0 closed .. 100 open */

/* Sensor and actuator channels a port may offer. */
#define TINY_SENSOR_LIGHT 0
#define TINY_SENSOR_WEIGHT 1

/* ---- implemented by each device program -------------------------------- */
/* The node id to use unless the port is told otherwise. */
uint16_t app_default_id(void);
/* Once, after tiny_init and before the first tiny_poll. */
void app_setup(tiny_kernel *k);
/* After every tiny_poll. */
void app_loop(tiny_kernel *k, uint32_t now_ms);

/* ---- implemented by each port ------------------------------------------ */
/* Reports an event of the device (a line "<event> <value>" on the host, a
 * UART line or an LED on a board). */
void tiny_port_report(const char *event, long value);
/* Reads a sensor channel (TINY_SENSOR_*). */
long tiny_port_sensor(uint8_t channel);

/* The node id a port uses: TINY_NODE_ID when the build sets it, else the
 * program's app_default_id(). */
static inline uint16_t tiny_port_node_id(void) {
#ifdef TINY_NODE_ID
  return TINY_NODE_ID;
#else
  return app_default_id();
#endif
}

/* ---- helpers for device programs (tiny_app.c) -------------------------- */
/* Writes v as ASCII decimal into buf (cap >= 12); returns the length. */
uint8_t tiny_format_long(long v, char *buf, uint8_t cap);
/* Sets own tuple [key] to v as ASCII decimal text; returns tiny_set's result. */
int tiny_set_long(tiny_kernel *k, uint16_t key, long v);
/* Parses ASCII decimal data (optional '-'); returns 0 on success. */
int tiny_parse_long(const uint8_t *data, uint8_t len, long *out);

#ifdef __cplusplus
}
#endif

#endif /* TINY_APP_H */
