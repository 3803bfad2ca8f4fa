/* Blind (tiny PEIS 4): subscribed to key 43 (TiltValue) of PEIS 3 (the
 * plant); 0 closes the blind, anything else opens it that far. The
 * position is published as its own tuple 46 (BlindPosition). */
#include "tiny_app.h"

#define BLIND_ID 4
#define BLIND_SOURCE 3 /* the plant */

uint16_t app_default_id(void) { return BLIND_ID; }

static void on_tilt(tiny_kernel *k, const tiny_tuple *t, void *user) {
  long tilt;
  (void)user;
  if (tiny_parse_long(tiny_tuple_data(t), t->data_len, &tilt) != 0) {
    tiny_port_report("blind bad-value", (long)t->data_len);
    return;
  }
  if (tilt == 0) {
    tiny_port_report("blind closed", 0); /* drive the motor shut here */
  } else {
    tiny_port_report("blind open", tilt);
  }
  (void)tiny_set_long(k, TINY_KEY_BLIND_POSITION, tilt); /* tell the ecology */
}

void app_setup(tiny_kernel *k) {
  tiny_key key = tiny_key1(TINY_KEY_TILT_VALUE);
  if (tiny_subscribe(k, BLIND_SOURCE, &key, 0, on_tilt, 0) < 0)
    tiny_port_report("blind subscribe-failed", 0);
}

void app_loop(tiny_kernel *k, uint32_t now_ms) {
  (void)k;
  (void)now_ms;
}
