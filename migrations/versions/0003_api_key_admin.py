"""api_keys.is_admin: only admin keys manage keys; the embedded default's first local key is one

Revision ID: 0003
Revises: 0002
"""

from __future__ import annotations

import sqlalchemy as sa
from alembic import op

revision = "0003"
down_revision = "0002"
branch_labels = None
depends_on = None


def upgrade() -> None:
    with op.batch_alter_table("api_keys", schema=None) as batch_op:
        batch_op.add_column(sa.Column("is_admin", sa.Boolean(), nullable=False, server_default=sa.false()))
    # An existing embedded install keeps managing keys with the key `rigforge serve` made for it.
    keys = sa.table("api_keys", sa.column("id", sa.Uuid()), sa.column("name", sa.String()),
                    sa.column("created_at", sa.DateTime()), sa.column("is_admin", sa.Boolean()))
    first_local = sa.select(keys.c.id).where(keys.c.name == "local").order_by(keys.c.created_at).limit(1).scalar_subquery()
    op.execute(keys.update().where(keys.c.id == first_local).values(is_admin=True))


def downgrade() -> None:
    with op.batch_alter_table("api_keys", schema=None) as batch_op:
        batch_op.drop_column("is_admin")
