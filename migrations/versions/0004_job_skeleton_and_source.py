"""jobs.skeleton_asset_id (an edited skeleton to re-skin with) and jobs.source_job_id (the job it was edited from)

Revision ID: 0004
Revises: 0003
"""

from __future__ import annotations

import sqlalchemy as sa
from alembic import op

revision = "0004"
down_revision = "0003"
branch_labels = None
depends_on = None


def upgrade() -> None:
    with op.batch_alter_table("jobs", schema=None) as batch_op:
        batch_op.add_column(sa.Column("skeleton_asset_id", sa.Uuid(), nullable=True))
        batch_op.add_column(sa.Column("source_job_id", sa.Uuid(), nullable=True))
        batch_op.create_foreign_key("fk_jobs_skeleton_asset", "assets", ["skeleton_asset_id"], ["id"])
        batch_op.create_foreign_key("fk_jobs_source_job", "jobs", ["source_job_id"], ["id"])


def downgrade() -> None:
    with op.batch_alter_table("jobs", schema=None) as batch_op:
        batch_op.drop_constraint("fk_jobs_source_job", type_="foreignkey")
        batch_op.drop_constraint("fk_jobs_skeleton_asset", type_="foreignkey")
        batch_op.drop_column("source_job_id")
        batch_op.drop_column("skeleton_asset_id")
